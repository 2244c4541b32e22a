"""The waypoints mode: go to (x, y, heading) targets in order, settling at each.

A `WaypointFollower` closes the loop on the robot's measured root: each tick it turns the
error from the measured pose to the current target into a velocity command
(`root_spring.waypoint_command`, with a stop band around the target so that the robot
stands instead of shuffling on the spot), decides when the robot has settled there
(within the tolerances and slow for a short hold), records the error at that moment and
moves on; after the last target it commands zero. Run without the planner it is the plain
go-to-pose loop (`WaypointReference`); with the planner, `PlannedReference` plans from its
command. No MuJoCo, no torch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from controller.inputs.base import ZERO, CommandLimits, VelocityCommand
from controller.inputs.scripted import Waypoint
from controller.reference.root_spring import RootState, waypoint_command
from controller.reference.source import ReferenceSource
from controller.reference.window import ReferenceWindow
from hw import quat
from hw.errors import ConfigError
from hw.types import RobotState


@dataclass(frozen=True)
class WaypointConfig:
    """How the follower walks to a target and when it counts as there.

    The approach (`max_speed`, `slow_radius`, `max_yaw_rate`, `slow_angle`) is
    `root_spring.waypoint_command`'s. Inside `stop_radius` (m) the planar command is zero
    and inside `stop_angle_deg` the yaw rate is zero: the policy then stands still, where
    a command of a few cm/s makes it step on the spot and drift. Settled: within
    `position_tolerance` (m) and `heading_tolerance_deg`, slower than `settle_speed` (m/s)
    and `settle_yaw_rate` (rad/s), for `settle_hold_s` without a break.
    """

    max_speed: float = 0.6
    max_yaw_rate: float = 1.0
    slow_radius: float = 0.5
    turn_radius: float = 0.5
    slow_angle: float = 0.5
    min_speed: float = 0.1
    min_yaw_rate: float = 0.15
    stop_radius: float = 0.04
    stop_angle_deg: float = 1.5
    position_tolerance: float = 0.05
    heading_tolerance_deg: float = 3.0
    settle_speed: float = 0.1
    settle_yaw_rate: float = 0.2
    settle_hold_s: float = 0.3

    def __post_init__(self) -> None:
        for name in (
            "max_speed",
            "max_yaw_rate",
            "slow_radius",
            "turn_radius",
            "slow_angle",
            "position_tolerance",
            "heading_tolerance_deg",
            "settle_speed",
            "settle_yaw_rate",
        ):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ConfigError(f"waypoint {name} must be a positive number, got {value!r}")
        for name in ("min_speed", "min_yaw_rate", "stop_radius", "stop_angle_deg", "settle_hold_s"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"waypoint {name} must be a non-negative number, got {value!r}")
        if self.stop_radius >= self.position_tolerance or self.stop_angle_deg >= self.heading_tolerance_deg:
            raise ConfigError(
                "the stop band must lie inside the tolerances (stop_radius < position_tolerance, stop_angle_deg < heading_tolerance_deg)"
            )


@dataclass(frozen=True)
class WaypointError:
    """How far from its target the robot was when it settled there."""

    position_m: float
    heading_deg: float


class WaypointFollower:
    """Holds the targets and the progress; `command(state)` each tick gives the velocity to follow."""

    def __init__(self, waypoints: Sequence[Waypoint], cfg: WaypointConfig = WaypointConfig(), limits: CommandLimits | None = None) -> None:
        if not waypoints:
            raise ConfigError("a waypoint follower needs at least one waypoint")
        self.cfg = cfg
        self.targets = tuple((float(w.x), float(w.y), math.radians(float(w.heading_deg))) for w in waypoints)
        self.limits = limits
        self.index = 0  # the target being walked to; len(targets) once all are reached
        self.errors: list[WaypointError] = []
        self.start_time: float | None = None
        self.done_time: float | None = None
        self._rest_since: float | None = None  # run time since which the robot has been slower than the settle speeds
        self._hold_position = False  # in the stop band: planar command zero until the error leaves the tolerance
        self._hold_heading = False  # the same for the heading

    @property
    def done(self) -> bool:
        return self.index >= len(self.targets)

    def start(self, time: float) -> None:
        """The run begins at `time`; a restart (after a fall) keeps the progress and the start time."""
        if self.start_time is None:
            self.start_time = time
        self._rest_since = None

    def errors_to(self, state: RobotState) -> tuple[float, float]:
        """Distance (m) and heading error (rad, wrapped) from the measured root to the current target."""
        tx, ty, th = self.targets[min(self.index, len(self.targets) - 1)]
        distance = math.hypot(tx - float(state.base_pos[0]), ty - float(state.base_pos[1]))
        heading_error = float(quat.wrap_angle(th - float(quat.heading(state.base_quat))))
        return distance, heading_error

    def command(self, state: RobotState) -> VelocityCommand:
        """The velocity command (heading frame) of this tick; also advances to the next target once settled."""
        if self.start_time is None:
            self.start(state.time)
        if self.done:
            return ZERO
        distance, heading_error = self.errors_to(state)
        if self._settled(state, distance, heading_error):
            self.errors.append(WaypointError(round(distance, 4), round(math.degrees(abs(heading_error)), 3)))
            self.index += 1
            self._hold_position = self._hold_heading = False
            if self.done:
                self.done_time = state.time
                return ZERO
            distance, heading_error = self.errors_to(state)
        return self._approach(state, distance, heading_error)

    def _approach(self, state: RobotState, distance: float, heading_error: float) -> VelocityCommand:
        """`waypoint_command` towards the target, with a floor on small commands and a stop band with hysteresis."""
        cfg = self.cfg
        root = RootState(
            position=(float(state.base_pos[0]), float(state.base_pos[1])),
            velocity=(0.0, 0.0),
            heading=float(quat.heading(state.base_quat)),
            yaw_rate=0.0,
        )
        target = self.targets[self.index]
        cmd = waypoint_command(root, target, cfg.max_speed, cfg.max_yaw_rate, cfg.slow_radius, cfg.slow_angle)
        turn = waypoint_command(root, target, cfg.max_speed, cfg.max_yaw_rate, cfg.turn_radius, cfg.slow_angle)
        near = distance <= cfg.turn_radius  # inside, the yaw command turns to the target heading
        at_rest = self._at_rest(state.time)
        position_out = distance > cfg.position_tolerance and (at_rest or distance > 2.0 * cfg.position_tolerance)
        self._hold_position = not position_out if self._hold_position else distance <= cfg.stop_radius
        heading_tolerance = math.radians(cfg.heading_tolerance_deg)
        heading_out = abs(heading_error) > heading_tolerance and (at_rest or abs(heading_error) > 2.0 * heading_tolerance)
        self._hold_heading = near and (not heading_out if self._hold_heading else abs(heading_error) <= math.radians(cfg.stop_angle_deg))
        vx, vy, yaw_rate = cmd.vx, cmd.vy, turn.yaw_rate
        if self._hold_position:
            vx = vy = 0.0
        else:
            speed = math.hypot(vx, vy)
            if 0.0 < speed < cfg.min_speed:
                vx, vy = vx * cfg.min_speed / speed, vy * cfg.min_speed / speed
        if self._hold_heading:
            yaw_rate = 0.0
        elif near and yaw_rate != 0.0 and abs(yaw_rate) < cfg.min_yaw_rate:
            yaw_rate = math.copysign(cfg.min_yaw_rate, yaw_rate)
        cmd = VelocityCommand(vx, vy, yaw_rate)
        return self.limits.clamp(cmd) if self.limits is not None else cmd

    def _settled(self, state: RobotState, distance: float, heading_error: float) -> bool:
        """On the target, at rest for `settle_hold_s`."""
        cfg = self.cfg
        speed = math.hypot(float(state.base_lin_vel[0]), float(state.base_lin_vel[1]))
        yaw_rate = float(quat.rotate(state.base_quat, state.base_ang_vel)[2])  # the gyro's world z
        if speed <= cfg.settle_speed and abs(yaw_rate) <= cfg.settle_yaw_rate:
            if self._rest_since is None:
                self._rest_since = state.time
        else:
            self._rest_since = None
        on_target = distance <= cfg.position_tolerance and abs(heading_error) <= math.radians(cfg.heading_tolerance_deg)
        return on_target and self._at_rest(state.time)

    def _at_rest(self, time: float) -> bool:
        return self._rest_since is not None and time - self._rest_since >= self.cfg.settle_hold_s - 1e-9

    def report(self) -> dict[str, Any]:
        """Per-waypoint errors at settling, the time from the start to the last one settled (None: not reached)."""
        done = self.done_time is not None and self.start_time is not None
        return {
            "waypoints_reached": len(self.errors),
            "waypoint_errors": [{"position_m": e.position_m, "heading_deg": e.heading_deg} for e in self.errors],
            "waypoint_time_s": round(self.done_time - self.start_time, 3) if done else None,  # type: ignore[operator]
        }


class WaypointReference(ReferenceSource):
    """Waypoints without the planner: the follower's command is the window's velocity (the plain go-to-pose loop).

    The supervised velocity is not used: a waypoint scenario's own steps command zero.
    """

    def __init__(self, follower: WaypointFollower) -> None:
        self.follower = follower

    def start(self, state: RobotState) -> None:
        self.follower.start(state.time)

    def window(self, state: RobotState, velocity: VelocityCommand, gesture: str = "") -> ReferenceWindow:
        return ReferenceWindow(state.time, self.follower.command(state))  # gestures need the planner

    def report(self) -> dict[str, Any]:
        return self.follower.report()
