"""What motor emulators see of the physics: joint states in, joint-side PD commands out."""

from __future__ import annotations

import threading
import time
from typing import Protocol


class Plant(Protocol):
    lock: threading.RLock

    def time(self) -> float:
        """Physics time (s)."""

    def joint_state(self, joint: str) -> tuple[float, float, float]:
        """Joint-side position (rad), velocity (rad/s) and applied torque (N m)."""

    def set_joint_command(self, joint: str, q: float, dq: float, kp: float, kd: float, tau: float) -> None:
        """The PD law the motor now applies, joint side, until the next call."""

    def imu_reading(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """Quaternion (w, x, y, z), angular velocity (rad/s) and specific force (m/s^2) in the IMU frame."""


class StaticPlant:
    """A plant that holds every joint still at a pose: for benchmarks and bench tests
    without physics. Its time is the wall clock, so firmware watchdogs run in real time."""

    def __init__(self, pose: dict[str, float], clock: object = None) -> None:
        self.lock = threading.RLock()
        self._pose = dict(pose)
        self._clock = clock or time.monotonic
        self.commands: dict[str, tuple[float, float, float, float, float]] = {}

    def time(self) -> float:
        return float(self._clock())  # type: ignore[operator]

    def joint_state(self, joint: str) -> tuple[float, float, float]:
        return self._pose[joint], 0.0, 0.0

    def set_joint_command(self, joint: str, q: float, dq: float, kp: float, kd: float, tau: float) -> None:
        self.commands[joint] = (q, dq, kp, kd, tau)

    def imu_reading(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        return (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 9.81)
