"""Velocity-tracking metrics of a run: commanded against measured, in the heading frame.

Measured velocity is the pelvis displacement over each control tick (smoother than the
instantaneous pelvis velocity, which sways with every step), rotated into the frame of
the pelvis heading. Error means skip `settle` seconds after every command change: the
policy needs that long to reach a new speed, and the report is about steady tracking.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from controller.inputs.base import VelocityCommand
from hw import quat
from hw.types import FloatArray


@dataclass
class TrackingMetrics:
    settle: float = 0.5
    times: list[float] = field(default_factory=list)
    commanded: list[tuple[float, float, float]] = field(default_factory=list)
    measured: list[tuple[float, float, float]] = field(default_factory=list)
    _vel_errors: list[float] = field(default_factory=list)
    _yaw_errors: list[float] = field(default_factory=list)
    _prev: tuple[float, float, float, float] | None = None
    _last_command: VelocityCommand | None = None
    _changed_at: float = 0.0

    def reset_reference(self) -> None:
        """Forget the previous pose (after a reset the displacement is meaningless)."""
        self._prev = None

    def record(self, t: float, base_pos: FloatArray, base_quat: FloatArray, command: VelocityCommand) -> None:
        yaw = float(quat.heading(base_quat))
        if command != self._last_command:
            self._last_command = command
            self._changed_at = t
        px, py = float(base_pos[0]), float(base_pos[1])
        prev, self._prev = self._prev, (t, px, py, yaw)
        if prev is None or t <= prev[0]:
            return
        dt = t - prev[0]
        wx, wy = (px - prev[1]) / dt, (py - prev[2]) / dt
        c, s = math.cos(yaw), math.sin(yaw)
        vx, vy = c * wx + s * wy, -s * wx + c * wy
        wz = float(quat.wrap_angle(yaw - prev[3])) / dt
        self.times.append(t)
        self.commanded.append((command.vx, command.vy, command.yaw_rate))
        self.measured.append((vx, vy, wz))
        if t - self._changed_at >= self.settle:
            self._vel_errors.append(math.hypot(vx - command.vx, vy - command.vy))
            self._yaw_errors.append(abs(wz - command.yaw_rate))

    @property
    def velocity_error_mean(self) -> float:
        return float(np.mean(self._vel_errors)) if self._vel_errors else float("nan")

    @property
    def yaw_rate_error_mean(self) -> float:
        return float(np.mean(self._yaw_errors)) if self._yaw_errors else float("nan")
