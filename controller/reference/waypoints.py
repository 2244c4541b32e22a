"""The waypoints mode: go to (x, y, heading) targets in order, settling at each.

A `WaypointFollower` closes the loop on the robot's measured root: each tick it turns the
error from the measured pose to the current target into a velocity command
(`root_spring.waypoint_command`, with a floor on small commands and a stop band, both
measured on the locomotion policy), decides when the robot has settled there (on target
and at rest for a short hold), records the error at that moment and moves on; after the
last target it commands zero. Without the planner the follower's command is the window's
velocity (`WaypointReference`: the plain go-to-pose loop). With the planner
(`PlannedReference`) the legs follow the same command (the decoupled tracker's
`legs_follow: command`), and the planner walks its own root to the same target
(`plan_command`), so the plan and the robot meet at every waypoint.

Measured on the `waypoints` scenario: with the legs on the spring path's or the plan's
own velocity instead, the robot reached none of the 4 poses in 45 s (2 and 0 of them
when the planner was asked for the robot's command): the planned root answers a command
late and drifts, and only feedback from the measured root brings the robot onto a
target. No MuJoCo, no torch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from controller.commands.velocity import ZERO, CommandLimits, VelocityCommand
from controller.commands.waypoints import WorldWaypoint
from controller.reference.root_spring import RootState, SpringConfig, no_overshoot_gain, waypoint_command
from controller.reference.source import ReferenceSource
from controller.reference.window import ReferenceWindow
from hw import g1, quat
from hw.errors import ConfigError
from hw.types import FloatArray, RobotState


@dataclass(frozen=True)
class WaypointConfig:
    """How the follower walks to a target and when it counts as there.

    The approach is `root_spring.waypoint_command`'s: `max_speed` (m/s), proportionally
    slower inside `slow_radius` (m); `max_yaw_rate` (rad/s) times the heading error over
    `slow_angle` (rad); facing the target point beyond twice `slow_radius` and the target
    heading inside it (turning while walking in: facing the point to 0.15 m and turning
    on the spot there took 26-36 s for the `waypoints` square against 22-27, a turn on
    the spot carrying the pelvis up to 8 cm). The fastsac policy walks about 0.045 m/s slower than commanded at
    small speeds (0.06 for 0.1) and a stop carries it about 4.4 cm on whatever the speed,
    so a planar command never drops below `min_speed` (nor a yaw rate near the target
    below `min_yaw_rate`), and the command is zero inside `stop_radius` (about one stop's
    carry) and `stop_angle_deg`. That stop holds until the robot has come to rest outside
    the tolerance (or is pushed twice as far), so the stop's own carry does not restart
    the walk. Settled: within `position_tolerance` (m) and `heading_tolerance_deg`, and
    slower than `settle_speed` (m/s) and `settle_yaw_rate` (rad/s) for `settle_hold_s`.
    """

    max_speed: float = 0.6
    max_yaw_rate: float = 1.0
    slow_radius: float = 0.5
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


class Follower(Protocol):
    """What the planned reference steers by in the waypoints mode: a `WaypointFollower`, or a curve's (`curves.py`)."""

    @property
    def done(self) -> bool: ...

    @property
    def errors(self) -> list[WaypointError]: ...

    def start(self, state: RobotState) -> None: ...

    def command(self, state: RobotState) -> VelocityCommand: ...

    def plan_command(self, qpos: FloatArray, spring: SpringConfig | None = None) -> VelocityCommand: ...

    def report(self) -> dict[str, Any]: ...


@dataclass(frozen=True)
class WaypointError:
    """How far from its target the robot was when it settled there."""

    position_m: float
    heading_deg: float
    time: float  # when it settled (run time line)
    target: tuple[float, float, float]  # x, y (m), heading (rad)


class WaypointFollower:
    """Holds the targets and the progress; `command(state)` each tick gives the velocity to follow."""

    def __init__(
        self, waypoints: Sequence[WorldWaypoint], cfg: WaypointConfig = WaypointConfig(), limits: CommandLimits | None = None
    ) -> None:
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

    def start(self, state: RobotState) -> None:
        """The run begins (its start time is `state.time`); a restart after a fall keeps the progress and the start time."""
        _check_position(state)
        if self.start_time is None:
            self.start_time = state.time
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
            self.start(state)
        _check_position(state)
        if self.done:
            return ZERO
        distance, heading_error = self.errors_to(state)
        if self._settled(state, distance, heading_error):
            target = self.targets[self.index]
            self.errors.append(WaypointError(round(distance, 4), round(math.degrees(abs(heading_error)), 3), state.time, target))
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
        near = distance <= cfg.slow_radius  # inside, the yaw command turns to the target heading
        at_rest = self._at_rest(state.time)
        position_out = distance > cfg.position_tolerance and (at_rest or distance > 2.0 * cfg.position_tolerance)
        self._hold_position = not position_out if self._hold_position else distance <= cfg.stop_radius
        heading_tolerance = math.radians(cfg.heading_tolerance_deg)
        heading_out = abs(heading_error) > heading_tolerance and (at_rest or abs(heading_error) > 2.0 * heading_tolerance)
        self._hold_heading = near and (not heading_out if self._hold_heading else abs(heading_error) <= math.radians(cfg.stop_angle_deg))
        vx, vy, yaw_rate = cmd.vx, cmd.vy, cmd.yaw_rate
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

    def plan_command(self, qpos: FloatArray, spring: SpringConfig | None = None) -> VelocityCommand:
        """The go-to-pose command for the planned root at `qpos` [36]: towards the current target (the last one when done).

        The planner continues its own frames, open loop: fed the robot's command, its root
        drifted 1.6 m and 70 degrees from the robot's on average over the `waypoints`
        square. Walked to the same target from where the plan is, plan and robot meet at
        every waypoint. The gains are the springs' no-overshoot bound (`no_overshoot_gain`):
        no floor, no stop band (the spring path has no dead band), and the plan's root
        answers a command late, so faster gains made it circle the target (measured mean
        root and heading errors, seeds 0 and 1: 0.36-0.38 m and 21-31 degrees at the bound,
        0.49 m and 43 degrees with the robot's gains).
        """
        cfg, spring = self.cfg, spring or SpringConfig()
        target = self.targets[min(self.index, len(self.targets) - 1)]
        heading = float(quat.heading(qpos[g1.QPOS_ROOT_QUAT]))
        root = RootState(position=(float(qpos[0]), float(qpos[1])), velocity=(0.0, 0.0), heading=heading, yaw_rate=0.0)
        slow_radius = cfg.max_speed / no_overshoot_gain(spring.velocity_halflife)
        slow_angle = cfg.max_yaw_rate / no_overshoot_gain(spring.heading_halflife)
        cmd = waypoint_command(root, target, cfg.max_speed, cfg.max_yaw_rate, slow_radius, slow_angle)
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
        elapsed = None
        if self.done_time is not None and self.start_time is not None:
            elapsed = round(self.done_time - self.start_time, 3)
        return {
            "waypoints_reached": len(self.errors),
            "waypoint_errors": [{"position_m": e.position_m, "heading_deg": e.heading_deg} for e in self.errors],
            "waypoint_time_s": elapsed,
        }


def _check_position(state: RobotState) -> None:
    if not state.has_base_position:
        raise ConfigError(
            "the waypoints mode walks to positions, but this robot's state has no base position estimate "
            "(the simulator gives it; elsewhere the state estimator does: --estimator)"
        )


class WaypointReference(ReferenceSource):
    """Waypoints without the planner: the follower's command is the window's velocity (the plain go-to-pose loop).

    The supervised velocity is not used: a waypoint scenario's own steps command zero.
    """

    needs_base_position = True
    follower: WaypointFollower

    def __init__(self, follower: WaypointFollower) -> None:
        self.follower = follower

    def start(self, state: RobotState) -> None:
        self.follower.start(state)

    def window(self, state: RobotState, velocity: VelocityCommand, gesture: str = "", hold: bool = False) -> ReferenceWindow:
        return ReferenceWindow(state.time, velocity if hold else self.follower.command(state))  # gestures need the planner

    def report(self) -> dict[str, Any]:
        return self.follower.report()
