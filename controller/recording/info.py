"""`g1ctl log info`: what a recording holds, in a few lines: the run, the span, each topic's count and rate, faults and modes."""

from __future__ import annotations

from pathlib import Path

from controller.recording import topics
from controller.recording.reader import Recording, read_recording

MAX_LINES = 40  # faults and mode changes printed; a run that flapped says how many more there were
LEVELS = {0: "UNKNOWN", 1: "DEBUG", 2: "INFO", 3: "WARNING", 4: "ERROR", 5: "FATAL"}


def log_lines(recording: Recording) -> list[tuple[float, str, str, str]]:
    """The kept `/log` topic as (time s, level name, source, text)."""
    return [(t, LEVELS.get(m.level, str(m.level)), m.name, m.message) for t, m in recording.decoded(topics.LOG)]


def describe(recording: Recording) -> list[str]:
    """The lines `g1ctl log info` prints, for a recording read with `/log` kept."""
    state = "complete" if recording.complete else "cut off before its footer"
    lines = [f"file: {recording.path} ({recording.size / 1e6:.2f} MB, {state}, {recording.messages} messages)"]
    run = recording.run
    if run:
        where = f"tracker {run.get('tracker', '?')} at {run.get('rate_hz', '?')} Hz on {run.get('backend', '?')}"
        lines.append(f"run: {where}, started {run.get('started', '?')}")
    recorder = recording.metadata.get("recorder")
    if recorder is not None:
        stopped = f", the writer stopped: {recorder['error']}" if "error" in recorder else ""
        lines.append(f"recorder: {recorder.get('offered', '?')} ticks, {recorder.get('drops', '?')} dropped{stopped}")
    span = recording.span_s
    lines.append(f"span: {span[0]:.3f} s to {span[1]:.3f} s ({span[1] - span[0]:.3f} s)" if span is not None else "span: no messages")
    lines.append(f"{'topic':<22}{'schema':<28}{'messages':>9}{'rate':>11}")
    for name, stats in sorted(recording.topics.items()):
        seconds = ((stats.last_ns or 0) - (stats.first_ns or 0)) / 1e9
        rate = f"{(stats.count - 1) / seconds:.1f} Hz" if stats.count > 1 and seconds > 0 else "-"
        lines.append(f"{name:<22}{stats.schema:<28}{stats.count:>9}{rate:>11}")
    logs = log_lines(recording) if topics.LOG.name in recording.kept else []
    faults = [(t, source, text) for t, level, source, text in logs if level in ("ERROR", "FATAL")]
    lines.append(f"faults: {len(faults)}" if faults else "faults: none")
    lines += [f"  {t:9.3f} s  {source}: {text}" for t, source, text in faults[:MAX_LINES]]
    modes = [f"{t:.3f} s {text.removeprefix('mode ')}" for t, _, source, text in logs if source == "supervisor"]
    lines.append("modes: " + ("; ".join(modes[:MAX_LINES]) or "none recorded"))
    for more in (len(faults) - MAX_LINES, len(modes) - MAX_LINES):
        if more > 0:
            lines.append(f"  ... and {more} more lines on {topics.LOG.name}")
    return lines


def info(path: Path) -> tuple[list[str], str | None]:
    """The lines to print and, for a file cut off, the one-line warning."""
    recording = read_recording(path, keep={topics.LOG.name})
    return describe(recording), recording.warning()
