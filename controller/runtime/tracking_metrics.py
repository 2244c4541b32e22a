"""Velocity-tracking metrics of a run: commanded against measured, in the heading frame.

Measured velocity is the pelvis displacement over each control tick (smoother than the
instantaneous pelvis velocity, which sways with every step), rotated into the frame of
the pelvis heading. Error means skip `settle` seconds after every command change: the
policy needs that long to reach a new speed, and the report is about steady tracking.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from controller.commands.velocity import VelocityCommand
from controller.reference.buffer import ReferenceSample
from hw import g1, quat
from hw.types import FloatArray, RobotState


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

    def record(self, t: float, base_pos: FloatArray, base_quat: FloatArray, command: VelocityCommand) -> tuple[float, float, float] | None:
        """The velocity measured over the tick that ends at `t` (vx, vy, yaw rate in the heading frame); None at a first sample."""
        yaw = quat.heading_of(base_quat)
        if command != self._last_command:
            self._last_command = command
            self._changed_at = t
        px, py = float(base_pos[0]), float(base_pos[1])
        prev, self._prev = self._prev, (t, px, py, yaw)
        if prev is None or t <= prev[0]:
            return None
        dt = t - prev[0]
        wx, wy = (px - prev[1]) / dt, (py - prev[2]) / dt
        c, s = math.cos(yaw), math.sin(yaw)
        vx, vy = c * wx + s * wy, -s * wx + c * wy
        wz = quat.wrapped(yaw - prev[3]) / dt
        self.times.append(t)
        self.commanded.append((command.vx, command.vy, command.yaw_rate))
        self.measured.append((vx, vy, wz))
        if t - self._changed_at >= self.settle:
            self._vel_errors.append(math.hypot(vx - command.vx, vy - command.vy))
            self._yaw_errors.append(abs(wz - command.yaw_rate))
        return vx, vy, wz

    @property
    def velocity_error_mean(self) -> float:
        return float(np.mean(self._vel_errors)) if self._vel_errors else float("nan")

    @property
    def yaw_rate_error_mean(self) -> float:
        return float(np.mean(self._yaw_errors)) if self._yaw_errors else float("nan")


def command_response_s(
    times: Sequence[float], commanded: Sequence[tuple[float, float, float]], measured: Sequence[tuple[float, float, float]],
    window_s: float = 0.5, min_change: float = 0.1,
) -> tuple[float, int, int]:  # fmt: skip
    """Mean time from a planar command change until the measured velocity covers half of it.

    The measured velocity is averaged over a centred `window_s` (a step's sway would
    otherwise cross the half-way mark by chance); changes smaller than `min_change` m/s
    are skipped. Returns (mean seconds, changes answered, changes not answered before the
    next change or the end), NaN when none was answered. The same rule for runs with and
    without the planner, so they compare.
    """
    t = np.asarray(times, dtype=np.float64)
    if len(t) < 2:
        return float("nan"), 0, 0
    cmd = np.asarray(commanded, dtype=np.float64)[:, :2]
    meas = np.asarray(measured, dtype=np.float64)[:, :2]
    half = max(round(window_s / max(float(np.median(np.diff(t))), 1e-9) / 2), 0)
    kernel = np.ones(2 * half + 1) / (2 * half + 1)
    smooth = np.stack([np.convolve(np.pad(meas[:, i], half, mode="edge"), kernel, mode="valid") for i in range(2)], axis=-1)
    changes = [k for k in range(1, len(t)) if np.linalg.norm(cmd[k] - cmd[k - 1]) >= min_change]
    delays, unanswered = [], 0
    for n, k in enumerate(changes):
        end = changes[n + 1] if n + 1 < len(changes) else len(t)
        delta = cmd[k] - cmd[k - 1]
        covered = (smooth[k:end] - cmd[k - 1]) @ delta >= 0.5 * float(delta @ delta)
        if covered.any():
            delays.append(t[k + int(np.argmax(covered))] - t[k])
        else:
            unanswered += 1
    return (float(np.mean(delays)) if delays else float("nan")), len(delays), unanswered


@dataclass
class PlanTrackingMetrics:
    """How closely the robot follows the planned motion: root path, heading and upper-body joints.

    `planned` keeps the plan's root velocity in its heading frame per tick, for the plot.
    """

    upper_body: tuple[int, ...] = field(default_factory=lambda: tuple(g1.joint_indices(g1.UPPER_BODY_JOINTS)))
    times: list[float] = field(default_factory=list)
    planned: list[tuple[float, float, float]] = field(default_factory=list)
    _path: list[float] = field(default_factory=list)
    _heading: list[float] = field(default_factory=list)
    _upper: list[float] = field(default_factory=list)

    def record(self, t: float, measured: RobotState, plan: ReferenceSample) -> None:
        planned_xy = plan.qpos[g1.QPOS_ROOT_POS][:2]
        self._path.append(math.hypot(float(measured.base_pos[0] - planned_xy[0]), float(measured.base_pos[1] - planned_xy[1])))
        heading = quat.heading_of(plan.qpos[g1.QPOS_ROOT_QUAT])
        self._heading.append(abs(quat.wrapped(quat.heading_of(measured.base_quat) - heading)))
        index = list(self.upper_body)
        joints = plan.qpos[g1.QPOS_JOINTS]
        self._upper.append(float(np.mean(np.abs(measured.joint_pos[index] - joints[index]))))
        c, s = math.cos(heading), math.sin(heading)
        wx, wy = float(plan.root_velocity[0]), float(plan.root_velocity[1])
        self.times.append(t)
        self.planned.append((c * wx + s * wy, -s * wx + c * wy, float(plan.yaw_rate)))

    def report(self) -> dict[str, float]:
        def mean(values: list[float]) -> float:
            return round(float(np.mean(values)), 4) if values else float("nan")

        return {
            "root_path_error_mean": mean(self._path),
            "heading_error_mean": mean(self._heading),
            "upper_body_error_mean": mean(self._upper),
        }
