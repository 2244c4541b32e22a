"""What motor emulators see of the physics: joint states in, joint-side PD commands out."""

from __future__ import annotations

import threading
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
