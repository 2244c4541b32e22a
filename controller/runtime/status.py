"""One live status line in a terminal: run mode, command, measured velocity, plan latency.

A person driving with the keyboard or a gamepad sees what the robot was asked and what
it does, refreshed a few times a second on stderr, on one line.
"""

from __future__ import annotations

import time
from typing import TextIO

from controller.runtime.session import Session

REFRESH_S = 0.2  # wall seconds between refreshes


class StatusLine:
    def __init__(self, stream: TextIO, refresh_s: float = REFRESH_S) -> None:
        self.stream = stream
        self.refresh_s = refresh_s
        self._next = 0.0
        self._width = 0
        self._caption = ""

    def update(self, session: Session, caption: str = "") -> None:
        """Refresh the line (at most every `refresh_s`, and at once when the caption changed: a key typed into the text
        line); `caption`: what a job is doing now (the text plan's clause, an instruction being typed), at its end."""
        now = time.monotonic()
        if now < self._next and caption == self._caption:
            return
        self._next, self._caption = now + self.refresh_s, caption
        self._write(" | ".join(part for part in (format_status(session), caption) if part))

    def close(self) -> None:
        if self._width:
            self.stream.write("\n")
            self.stream.flush()

    def _write(self, text: str) -> None:
        pad = max(self._width - len(text), 0)
        self._width = len(text)
        self.stream.write("\r" + text + " " * pad)
        self.stream.flush()


MEASURED_SMOOTHING_S = 0.5  # the measured velocity shown is the mean of this long: smoother than one tick's displacement


def format_status(session: Session) -> str:
    """`t 12.3 s | run | cmd vx +0.50 vy +0.00 wz +0.00 | meas vx +0.47 vy -0.02 wz +0.01 | plan 2.8 ms`."""
    supervisor, metrics = session.supervisor, session.metrics
    window = session.last_window
    t = (window.time if window is not None else session.start_time) - session.start_time
    parts = [f"t {t:6.1f} s", supervisor.mode.value]
    if window is not None:
        c = window.velocity
        parts.append(f"cmd vx {c.vx:+.2f} vy {c.vy:+.2f} wz {c.yaw_rate:+.2f}")
    if metrics.measured:
        recent = metrics.measured[-max(1, round(MEASURED_SMOOTHING_S * session.tracker.rate_hz)) :]
        vx, vy, wz = (sum(v[i] for v in recent) / len(recent) for i in range(3))
        parts.append(f"meas vx {vx:+.2f} vy {vy:+.2f} wz {wz:+.2f}")
    latency = session.reference.report().get("plan_latency_ms")
    if isinstance(latency, dict) and latency.get("p50") == latency.get("p50"):  # not NaN
        parts.append(f"plan p50 {latency['p50']:.1f} ms")
    if supervisor.damp_reason:
        parts.append(supervisor.damp_reason)
    elif supervisor.hold_reason:
        parts.append(supervisor.hold_reason)
    return " | ".join(parts)
