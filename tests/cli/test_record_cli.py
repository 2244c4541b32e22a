"""`--record` on real runs and `g1ctl log` on their files, through the real CLI in a subprocess.

A short walk recorded and read back by `log info` (every topic, every tick), through simulated
buses too (the bus and estimator counters); a run stopped by Ctrl-C leaves a finished file, a
killed one a file that `log info` reads up to the cut; a path that cannot be written and a file
that is no MCAP are each one line.
"""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from controller.recording import topics
from controller.recording.reader import read_recording
from tests.conftest import HANG_S, g1ctl, one_line_error, wait_for

PER_TICK = ("/command", "/input", "/joints", "/reference", "/state", "/supervisor", "/tf", "/tracking")


def topic_counts(info: str) -> dict[str, int]:
    """`log info`'s topic table: topic -> messages."""
    return {m[1]: int(m[2]) for m in re.finditer(r"^(/\S+)\s+\S+\s+(\d+)\s", info, re.MULTILINE)}


@pytest.mark.slow
def test_a_recorded_walk_is_read_back_by_log_info_and_plot(tmp_path: Path) -> None:
    record, report_path = tmp_path / "walk.mcap", tmp_path / "walk.json"
    result = g1ctl("sim", "--duration", "3", "--record", str(record), "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    recorder = report["recorder"]
    assert recorder["path"] == str(record) and recorder["drops"] == 0 and recorder["ticks"] == 150
    assert recorder["bytes"] == record.stat().st_size and f"recording: {record} ({recorder['messages']} messages" in result.stdout
    info = g1ctl("log", "info", str(record))
    assert info.returncode == 0 and info.stderr == "", info.stderr
    counts = topic_counts(info.stdout)
    assert {topic: counts[topic] for topic in PER_TICK} == dict.fromkeys(PER_TICK, 150) and counts["/log"] == 1
    assert sum(counts.values()) == recorder["messages"]
    assert "complete" in info.stdout and "faults: none" in info.stdout and "modes: 0.000 s run" in info.stdout
    assert "span: 0.000 s to 2.980 s" in info.stdout and "tracker velocity at 50.0 Hz on DirectSimBackend" in info.stdout
    # the base where the recording leaves it is where the report says the run ended (one tick of walking apart at most)
    recording = read_recording(record, keep={topics.TF.name, topics.PAYLOAD_TOPICS["tracking"].name})
    last = recording.decoded(topics.TF)[-1][1].transforms[0].translation
    assert [last.x, last.y] == pytest.approx(report["final_base_position"][:2], abs=0.02)
    tracking = recording.decoded(topics.PAYLOAD_TOPICS["tracking"])
    assert {round(m.commanded.vx, 3) for t, m in tracking if 1.5 < t < 2.5} == {0.5}  # walk_turn_stop: 0.5 m/s from 1 s on
    plot = g1ctl("log", "plot", str(record), "--joints", "left_knee,right_hip_pitch_joint", "--out", str(tmp_path / "walk.png"))
    assert plot.returncode == 0, plot.stderr
    assert (tmp_path / "walk.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and (tmp_path / "walk.png").stat().st_size > 30_000
    wrong = one_line_error(g1ctl("log", "plot", str(record), "--joints", "left_elbow,tail"))
    assert "--joints tail: no such joint" in wrong and "left_knee, " in wrong


@pytest.mark.slow
def test_a_run_through_simulated_buses_records_the_counters_and_the_estimate(tmp_path: Path) -> None:
    record, report_path = tmp_path / "can.mcap", tmp_path / "can.json"
    result = g1ctl("sim", "--hardware", "sim-can", "--duration", "2", "--record", str(record), "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    recording = read_recording(record, keep={topics.PAYLOAD_TOPICS["bus"].name, topics.PAYLOAD_TOPICS["estimator"].name, "/tf"})
    assert recording.complete and report["recorder"]["drops"] == 0
    ticks = report["recorder"]["ticks"]
    for topic in (*PER_TICK, "/estimate", "/truth"):
        assert recording.topics[topic].count == ticks, topic
    bus = [message for _, message in recording.decoded(topics.PAYLOAD_TOPICS["bus"])]
    assert len(bus) >= 2 and bus[-1]["state"] == "active" and bus[-1]["faults"] == 0
    sent = [message["frames_sent"] for message in bus]
    assert sent == sorted(sent) and 0 < sent[-1] <= report["hw"]["frames_sent"]  # the report's count includes the damped shutdown
    estimator = [message for _, message in recording.decoded(topics.PAYLOAD_TOPICS["estimator"])]
    assert estimator[-1]["fault"] is None and 0 < estimator[-1]["updates"] <= report["estimator"]["updates"]
    frames = {t.child_frame_id for _, m in recording.decoded(topics.TF) for t in m.transforms}
    assert frames == {"pelvis", "pelvis_estimate"}  # the truth, and the estimate beside it


def start_recorded_run(record: Path, report: Path) -> subprocess.Popen[str]:
    """A minute's walk held to the wall clock, recording, in its own process (to be stopped by the test)."""
    args = ["sim", "--duration", "60", "--realtime", "--record", str(record), "--report", str(report)]
    process = subprocess.Popen([sys.executable, "-m", "controller.cli", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # a few chunks on disk (one a second): the run is well under way
    if not wait_for(lambda: size_on_disk(record) > 150_000, timeout=6 * HANG_S):
        process.kill()
        pytest.fail(f"the recording did not grow: {process.communicate()}")
    return process


def size_on_disk(path: Path) -> int:
    """0 until the file is there: the run's start-up check creates the path and removes it again, so it may vanish."""
    try:
        return path.stat().st_size
    except FileNotFoundError:
        return 0


@pytest.mark.slow
def test_ctrl_c_leaves_a_finished_recording(tmp_path: Path) -> None:
    record, report_path = tmp_path / "stopped.mcap", tmp_path / "stopped.json"
    process = start_recorded_run(record, report_path)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    report = json.loads(report_path.read_text())
    assert report["interrupted"] and report["run_seconds"] < 60 and report["recorder"]["drops"] == 0
    info = g1ctl("log", "info", str(record))
    assert info.returncode == 0 and info.stderr == "", info.stderr
    assert ", complete, " in info.stdout
    assert topic_counts(info.stdout)["/joints"] == report["recorder"]["ticks"] > 50


@pytest.mark.slow
def test_a_killed_run_leaves_a_file_log_info_reads_up_to_the_cut(tmp_path: Path) -> None:
    record = tmp_path / "killed.mcap"
    process = start_recorded_run(record, tmp_path / "killed.json")
    process.send_signal(signal.SIGKILL)
    process.communicate(timeout=60)
    info = g1ctl("log", "info", str(record))
    assert info.returncode == 0, info.stderr
    warning = info.stderr.strip().splitlines()
    assert len(warning) == 1 and "the file ends before its footer: the recording was cut off" in warning[0]
    assert "cut off before its footer" in info.stdout and topic_counts(info.stdout)["/joints"] > 50  # a second of ticks, at least
    plot = g1ctl("log", "plot", str(record), "--out", str(tmp_path / "killed.png"))
    assert plot.returncode == 0 and (tmp_path / "killed.png").is_file() and len(plot.stderr.strip().splitlines()) == 1


@pytest.mark.slow
def test_a_recording_path_that_cannot_be_written_is_refused_before_anything_starts(tmp_path: Path) -> None:
    report = tmp_path / "report.json"
    for command in (("sim", "--duration", "1"), ("run", "--headless", "--input", "scripted", "--duration", "1")):
        line = one_line_error(g1ctl(*command, "--record", "/proc/run.mcap", "--report", str(report)))
        assert line.startswith("g1ctl: error: --record /proc/run.mcap: cannot write it")
    assert not report.exists()  # no run started
    (tmp_path / "folder.mcap").mkdir()
    line = one_line_error(g1ctl("plan", "walk forward one meter", "--sim", "--record", str(tmp_path / "folder.mcap")))
    assert line.endswith("folder.mcap: that is a folder; give a file name ending in .mcap")


@pytest.mark.slow
def test_log_on_a_file_that_is_no_mcap_is_one_line(tmp_path: Path) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("not a recording\n")
    for command in (("info",), ("plot",), ("replay", "--video", str(tmp_path / "v.mp4"))):
        line = one_line_error(g1ctl("log", command[0], str(notes), *command[1:]))
        assert (
            line == f"g1ctl: error: {notes} is not an MCAP file (it does not begin with MCAP's magic bytes): give a file made with --record"
        )
    assert "no such file" in one_line_error(g1ctl("log", "info", str(tmp_path / "missing.mcap")))


@pytest.mark.slow
def test_replay_renders_the_recorded_walk_with_the_plan_as_a_ghost(tmp_path: Path) -> None:
    record, video = tmp_path / "planned.mcap", tmp_path / "planned.gif"
    result = g1ctl("sim", "--planner", "--duration", "1", "--record", str(record))
    assert result.returncode == 0, result.stderr
    reference = read_recording(record, keep={topics.PAYLOAD_TOPICS["reference"].name}).decoded(topics.PAYLOAD_TOPICS["reference"])
    assert all(message.HasField("plan") and len(message.plan.qpos) == 36 for _, message in reference)  # a ghost on every frame
    replay = g1ctl("log", "replay", str(record), "--video", str(video), "--fps", "5")
    assert replay.returncode == 0, replay.stderr
    assert replay.stdout.strip() == f"video: {video} (5 frames)" and video.stat().st_size > 10_000
