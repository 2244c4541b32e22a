"""A `HardwareRobot` as a run backend: bus cycles at the hardware rate between control ticks.

No MuJoCo here: the same backend drives real buses (cycles paced on the wall clock) and
simulated hardware (the emulators and the physics step after each cycle, on simulated
time); only `now` and `after_cycle` differ.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from controller.reports import percentiles_ms
from controller.runtime.backend import Backend
from hw.hardware_robot import HardwareRobot, Lifecycle


class HardwareBackend(Backend):
    def __init__(self, host: HardwareRobot, config_name: str, now: Callable[[], float], after_cycle: Callable[[], None]) -> None:
        self.host = host
        self.robot = host
        self.config_name = config_name
        self._now = now
        self._after_cycle = after_cycle
        self.cycle_times: list[float] = []

    def start(self) -> None:
        """Configure (find every motor), then the soft start to the default pose; raises HardwareFault on a fault."""
        self.host.configure()
        self._after_cycle()
        self.host.activate()
        while self.host.state is Lifecycle.ACTIVATING:
            self.cycle()

    def cycle(self) -> None:
        t0 = time.perf_counter()
        self.host.cycle()
        self.cycle_times.append(time.perf_counter() - t0)
        self._after_cycle()

    def now(self) -> float:
        return self._now()

    def advance_to(self, t: float) -> None:
        while self._now() < t - 1e-9:
            self.cycle()

    def fault(self) -> str | None:
        return "; ".join(self.host.faults) if self.host.state is Lifecycle.ERROR else None

    def report(self) -> dict[str, Any]:
        c = self.host.counters()
        return {
            "config": self.config_name,
            "cycle_ms": percentiles_ms(self.cycle_times),
            "cycles": len(self.cycle_times),
            "frames_sent": c.frames_sent,
            "frames_received": c.frames_received,
            "dropped": c.dropped,
            "late_replies": c.late_replies,
            "crc_errors": c.crc_errors,
            "bad_frames": c.bad_frames,
            "unknown_ids": c.unknown_ids,
            "error_frames": c.error_frames,
        } | self.host.lifecycle_report()

    def close(self) -> None:
        self.host.close()
