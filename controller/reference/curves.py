"""Following a curved path without stopping: arcs as a velocity with a yaw rate, closed on the measured root.

A `CurveFollower` holds a path of arcs (radius, angle) placed from a start pose, and each
tick gives the velocity command that walks it: the path's own velocity where the robot is
along it (speed along the tangent, yaw rate speed over radius) plus a pull back onto it (the
cross-track error times `cross_gain`, the heading error times `heading_gain`). Its progress
is the nearest point of the path ahead of the last one, so it never runs backward along a
figure eight where the path crosses itself. Within `finish_m` of the end it hands over to a
`WaypointFollower` on the end pose, which stops and settles there like any waypoint: a
clause that ends on a curve ends at rest, on target.

The planner gets the same law from where its planned root is (`plan_command`), with its own
progress, as the waypoints mode does: plan and robot walk the same curve. No MuJoCo, no torch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from controller.commands.velocity import CommandLimits, VelocityCommand
from controller.commands.waypoints import WorldWaypoint
from controller.reference.root_spring import SpringConfig
from controller.reference.waypoints import WaypointConfig, WaypointError, WaypointFollower
from hw import g1, quat
from hw.errors import ConfigError
from hw.types import FloatArray, RobotState

Pose = tuple[float, float, float]  # x, y (m, world), heading (rad)


@dataclass(frozen=True)
class CurveConfig:
    cross_gain: float = 1.2  # 1/s: m/s of correction per m off the path
    heading_gain: float = 1.5  # 1/s: rad/s of correction per rad of heading error
    sample_m: float = 0.02  # the path is sampled this finely
    search_back_m: float = 0.1  # progress looks for the nearest point from this far behind ...
    search_ahead_m: float = 0.6  # ... to this far ahead of the last one
    finish_m: float = 0.25  # this close to the end (along the path), the end pose is walked to as a waypoint

    def __post_init__(self) -> None:
        for name in ("cross_gain", "heading_gain", "sample_m", "search_ahead_m", "finish_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"curve {name} must be a positive number, got {value!r}")


@dataclass(frozen=True)
class CurvePath:
    """The path sampled by arc length: positions [N, 2], headings [N] (rad, unwrapped), curvatures [N] (1/m, + left)."""

    positions: FloatArray
    headings: FloatArray
    curvatures: FloatArray
    step_m: float

    @property
    def length_m(self) -> float:
        return (len(self.headings) - 1) * self.step_m

    def end(self) -> Pose:
        return (float(self.positions[-1, 0]), float(self.positions[-1, 1]), float(self.headings[-1]))


def sample_path(start: Pose, arcs: Sequence[tuple[float, float]], step_m: float) -> CurvePath:
    """The arcs (radius m, angle rad + left) from `start`, sampled every `step_m` along the path (the ends exact)."""
    points = [(start[0], start[1])]
    headings = [start[2]]
    curvatures = []
    x, y, h = start
    for radius, angle in arcs:
        length = radius * abs(angle)
        n = max(1, math.ceil(length / step_m))
        kappa = math.copysign(1.0 / radius, angle)
        cx, cy = x - math.sin(h) / kappa, y + math.cos(h) / kappa  # the arc's centre
        for k in range(1, n + 1):
            hk = h + angle * k / n
            points.append((cx + math.sin(hk) / kappa, cy - math.cos(hk) / kappa))
            headings.append(hk)
            curvatures.append(kappa)
        x, y, h = points[-1][0], points[-1][1], headings[-1]
    curvatures.append(curvatures[-1])
    # resample to equal steps (arcs of different lengths give different steps)
    pts = np.asarray(points)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    grid = np.linspace(0.0, s[-1], max(2, round(s[-1] / step_m) + 1))
    positions = np.stack([np.interp(grid, s, pts[:, 0]), np.interp(grid, s, pts[:, 1])], axis=1)
    return CurvePath(positions, np.interp(grid, s, headings), np.interp(grid, s, curvatures), float(grid[1] - grid[0]))


class CurveFollower:
    """Walks a `CurvePath` from a start pose; the same interface as `WaypointFollower` (`done`, `command`, `plan_command`)."""

    def __init__(
        self,
        start: Pose,
        arcs: Sequence[tuple[float, float]],  # (radius m, angle rad + left)
        speed_mps: float,
        finish: WaypointConfig,
        limits: CommandLimits | None = None,
        cfg: CurveConfig = CurveConfig(),
    ) -> None:
        if not arcs or speed_mps <= 0:
            raise ConfigError("a curve follower needs at least one arc and a positive speed")
        self.cfg = cfg
        self.path = sample_path(start, arcs, cfg.sample_m)
        self.speed = speed_mps
        self.limits = limits
        x, y, h = self.path.end()
        self.final = WaypointFollower([WorldWaypoint(x, y, math.degrees(h))], finish, limits)
        self.progress = 0  # sample index the robot is at
        self._plan_progress = 0
        self.max_cross_track_m = 0.0
        self.start_time: float | None = None
        self.curve_time: float | None = None  # when the robot reached the finish (run time)

    @property
    def done(self) -> bool:
        return self.final.done

    @property
    def errors(self) -> list[WaypointError]:
        """The error at the end pose when the robot settled there (empty before)."""
        return self.final.errors

    @property
    def finishing(self) -> bool:
        return (len(self.path.headings) - 1 - self.progress) * self.path.step_m <= self.cfg.finish_m

    def start(self, state: RobotState) -> None:
        if self.start_time is None:
            self.start_time = state.time
        self.final.start(state)

    def command(self, state: RobotState) -> VelocityCommand:
        """This tick's velocity command (heading frame): along the curve, then to the end pose and settled there."""
        if self.start_time is None:
            self.start(state)
        pose = (float(state.base_pos[0]), float(state.base_pos[1]), float(quat.heading(state.base_quat)))
        self.progress, cross = self._advance(self.progress, pose)
        self.max_cross_track_m = max(self.max_cross_track_m, cross)
        if self.finishing:
            if self.curve_time is None:
                self.curve_time = state.time
            return self.final.command(state)
        return self._follow(self.progress, pose)

    def plan_command(self, qpos: FloatArray, spring: SpringConfig | None = None) -> VelocityCommand:
        """The same law for the planned root at `qpos` [36], with the plan's own progress; the end pose once it is near."""
        pose = (float(qpos[0]), float(qpos[1]), float(quat.heading(qpos[g1.QPOS_ROOT_QUAT])))
        self._plan_progress, _ = self._advance(self._plan_progress, pose)
        if self.finishing or (len(self.path.headings) - 1 - self._plan_progress) * self.path.step_m <= self.cfg.finish_m:
            return self.final.plan_command(qpos, spring)
        return self._follow(self._plan_progress, pose)

    def _advance(self, index: int, pose: Pose) -> tuple[int, float]:
        """The nearest sample to `pose` from a little behind `index` to a little ahead (never behind `index`), and the distance."""
        step = self.path.step_m
        lo = max(0, index - round(self.cfg.search_back_m / step))
        hi = min(len(self.path.headings), index + round(self.cfg.search_ahead_m / step) + 1)
        d = np.hypot(self.path.positions[lo:hi, 0] - pose[0], self.path.positions[lo:hi, 1] - pose[1])
        k = int(np.argmin(d))
        return max(index, lo + k), float(d[k])

    def _follow(self, index: int, pose: Pose) -> VelocityCommand:
        px, py = self.path.positions[index]
        th = float(self.path.headings[index])
        kappa = float(self.path.curvatures[index])
        # world velocity: along the tangent, plus the pull back onto the path
        vx_w = self.speed * math.cos(th) + self.cfg.cross_gain * (px - pose[0])
        vy_w = self.speed * math.sin(th) + self.cfg.cross_gain * (py - pose[1])
        c, s = math.cos(pose[2]), math.sin(pose[2])
        yaw_rate = self.speed * kappa + self.cfg.heading_gain * float(quat.wrap_angle(th - pose[2]))
        cmd = VelocityCommand(c * vx_w + s * vy_w, -s * vx_w + c * vy_w, yaw_rate)
        return self.limits.clamp(cmd) if self.limits is not None else cmd

    def report(self) -> dict[str, Any]:
        elapsed = None
        if self.final.done_time is not None and self.start_time is not None:
            elapsed = round(self.final.done_time - self.start_time, 3)
        return {
            "curve_length_m": round(self.path.length_m, 3),
            "curve_max_cross_track_m": round(self.max_cross_track_m, 4),
            "curve_time_s": elapsed,
        } | {k: v for k, v in self.final.report().items() if k == "waypoint_errors"}
