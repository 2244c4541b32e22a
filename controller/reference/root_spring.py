"""Smart locomotion: a velocity command becomes a smooth root path that the planner is asked to meet.

Why: a planner that is told only "walk at 0.5 m/s" decides on its own how fast to speed
up, and each replan may decide differently. MotionBricks' smart locomotion instead turns
the command into a root trajectory first, with a critically damped spring (Daniel
Holden's "Spring-It-On"), and asks the planner to meet the root position and heading at
the end of the plan (and at intermediate frames if wanted). The path is then smooth,
reacts to a new command at once, and two replans from the same state agree.

The yaw rate follows its own spring towards the commanded yaw rate, and the heading is
its closed-form integral. The planar velocity springs towards the commanded velocity
rotated into the world by the heading at that time, so walking while turning curves.
Note that such a spring lags a rotating goal: turning at w rad/s, the settled velocity
is y^2 / (y + i w)^2 times the commanded one, i.e. shorter by y^2 / (y^2 + w^2) and
behind the heading by 2 atan(w / y) (at the default halflife and w = 0.5 rad/s: 1.2 %
slower and 12 degrees behind, seen as a small sidestep to the outside in
`local_velocity`).

The halflife trades responsiveness for smoothness. With damping y = 2 ln2 / halflife, a
velocity change from rest is 40 % done after one halflife, half done after 1.21
halflives and 97 % done after four. The defaults (0.3 s for both springs) are a first
choice, to be tuned by measurement in the loop (does the tracked robot keep up with the
path, does the planner meet it).

Pure numpy: no MuJoCo, no torch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from controller.commands.velocity import VelocityCommand
from controller.planner.request import FPS, Keyframe, target_root
from hw import g1, quat
from hw.errors import ConfigError, G1Error

FloatArray = NDArray[np.float64]

ZERO_COMMAND = VelocityCommand()


class RootTrajectoryError(G1Error, ValueError):
    """A root state, frame count or frame array that no trajectory can be built from."""


@dataclass(frozen=True)
class SpringConfig:
    """Halflives (s) of the planar velocity spring and of the yaw-rate spring: shorter reacts faster, longer is smoother."""

    velocity_halflife: float = 0.3
    heading_halflife: float = 0.3

    def __post_init__(self) -> None:
        for name in ("velocity_halflife", "heading_halflife"):
            value = getattr(self, name)
            try:
                valid = not isinstance(value, bool) and math.isfinite(value) and value > 0
            except TypeError:
                valid = False
            if not valid:
                raise ConfigError(f"spring {name} must be a positive number of seconds, got {value!r}")


@dataclass(frozen=True, kw_only=True)
class RootState:
    """The root's planar state now: world position (m), velocity (m/s), acceleration (m/s^2); heading (rad, pelvis yaw) and its rates.

    Keyword-only, so a heading can never be passed where a yaw rate was meant.
    """

    position: tuple[float, float]
    velocity: tuple[float, float]
    heading: float
    yaw_rate: float
    acceleration: tuple[float, float] = (0.0, 0.0)
    yaw_acceleration: float = 0.0

    def __post_init__(self) -> None:
        for name in ("position", "velocity", "acceleration"):
            pair = tuple(float(v) for v in getattr(self, name))
            if len(pair) != 2 or not all(math.isfinite(v) for v in pair):
                raise RootTrajectoryError(f"root state {name} must be two finite numbers (world x, y), got {getattr(self, name)!r}")
            object.__setattr__(self, name, pair)
        for name in ("heading", "yaw_rate", "yaw_acceleration"):
            value = float(getattr(self, name))
            if not math.isfinite(value):
                raise RootTrajectoryError(f"root state {name} must be finite, got {value!r}")
            object.__setattr__(self, name, value)


@dataclass(frozen=True)
class RootTrajectory:
    """The root over the next plan: frame k is at `times[k]` = (k + 1) / fps s from now, plan frame k of the planner.

    `positions` [N, 2], `velocities` [N, 2] and `accelerations` [N, 2] are in the world;
    `headings` [N] are unwrapped (continuous from the state's heading); `yaw_rates` and
    `yaw_accelerations` [N] in rad/s and rad/s^2. The accelerations make `state_at`
    exact, so a trajectory can be continued from any of its frames without a kink.
    """

    times: FloatArray
    positions: FloatArray
    headings: FloatArray
    velocities: FloatArray
    yaw_rates: FloatArray
    accelerations: FloatArray
    yaw_accelerations: FloatArray

    @property
    def length(self) -> int:
        return len(self.times)

    def local_velocity(self, k: int) -> tuple[float, float]:
        """Velocity at frame k in the heading frame: (vx forward, vy left), m/s, what a velocity policy is commanded."""
        c, s = math.cos(self.headings[k]), math.sin(self.headings[k])
        vx, vy = self.velocities[k]
        return (float(c * vx + s * vy), float(-s * vx + c * vy))

    def state_at(self, k: int) -> RootState:
        """The spring state at frame k: continuing from it reproduces the rest of this trajectory (same command)."""
        return RootState(
            position=(float(self.positions[k, 0]), float(self.positions[k, 1])),
            velocity=(float(self.velocities[k, 0]), float(self.velocities[k, 1])),
            heading=float(self.headings[k]),
            yaw_rate=float(self.yaw_rates[k]),
            acceleration=(float(self.accelerations[k, 0]), float(self.accelerations[k, 1])),
            yaw_acceleration=float(self.yaw_accelerations[k]),
        )

    def root_keyframes(self, frames: Sequence[int] | None = None) -> tuple[Keyframe, ...]:
        """Root-only keyframes (position and heading) at plan `frames`; by default the last one, the end of the plan."""
        chosen = [self.length - 1] if frames is None else list(frames)
        bad = [k for k in chosen if not 0 <= k < self.length]
        if bad:
            raise RootTrajectoryError(f"frames {bad} are outside a root trajectory of {self.length} frames")
        return tuple(target_root(k, float(self.positions[k, 0]), float(self.positions[k, 1]), float(self.headings[k])) for k in chosen)


def _damping(halflife: float) -> float:
    """Spring-It-On's y: damping 4 ln2 / halflife, halved."""
    return 4.0 * math.log(2.0) / halflife / 2.0


def _spring_integral(
    x0: ArrayLike, v0: ArrayLike, a0: ArrayLike, goal: ArrayLike, y: float, t: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Closed form of a critically damped velocity spring: (position, velocity, acceleration) at time(s) t.

    Solves v'' = -2y v' - y^2 (v - goal) from v(0) = v0, v'(0) = a0, with x' = v, x(0) = x0.
    With j0 = v0 - goal, j1 = a0 + j0 y, e = exp(-y t):
    v = e (j0 + j1 t) + goal, a = e (a0 - j1 y t), and x integrates v from 0 to t.
    """
    x0, v0, a0, goal, t = (np.asarray(a, dtype=np.float64) for a in (x0, v0, a0, goal, t))
    j0 = v0 - goal
    j1 = a0 + j0 * y
    e = np.exp(-y * t)
    x = e * (-j1 / y**2 + (-j0 - j1 * t) / y) + j1 / y**2 + j0 / y + goal * t + x0
    v = e * (j0 + j1 * t) + goal
    a = e * (a0 - j1 * y * t)
    return x, v, a


def root_trajectory(
    state: RootState, command: VelocityCommand, frames: int, cfg: SpringConfig = SpringConfig(), fps: float = FPS
) -> RootTrajectory:
    """The root over the next `frames` frames at `fps` when `command` (heading frame) is held from now.

    The heading is the yaw-rate spring's closed form at every frame (exact). The planar
    velocity is stepped frame by frame with the closed form, the spring state carried
    over exactly, towards the command rotated by the heading at the middle of each frame
    interval: exact for a goal held over each frame, and within 0.05 mm of the
    continuously rotating goal over a 64-frame plan turning at 1 rad/s.
    """
    if not (isinstance(frames, int | np.integer) and frames >= 1):
        raise RootTrajectoryError(f"a root trajectory needs at least one frame, got frames={frames!r}")
    if not (math.isfinite(fps) and fps > 0):
        raise RootTrajectoryError(f"fps must be positive, got {fps!r}")
    cmd = (float(command.vx), float(command.vy), float(command.yaw_rate))
    if not all(math.isfinite(c) for c in cmd):
        raise RootTrajectoryError(f"velocity command must be finite, got {command!r}")
    dt = 1.0 / fps
    times = np.arange(1, frames + 1, dtype=np.float64) * dt

    y_yaw = _damping(cfg.heading_halflife)
    headings, yaw_rates, yaw_accelerations = _spring_integral(state.heading, state.yaw_rate, state.yaw_acceleration, cmd[2], y_yaw, times)
    mid_headings, _, _ = _spring_integral(state.heading, state.yaw_rate, state.yaw_acceleration, cmd[2], y_yaw, times - 0.5 * dt)

    y = _damping(cfg.velocity_halflife)
    p = np.array(state.position, dtype=np.float64)
    v = np.array(state.velocity, dtype=np.float64)
    a = np.array(state.acceleration, dtype=np.float64)
    c, s = np.cos(mid_headings), np.sin(mid_headings)
    goals = np.stack((c * cmd[0] - s * cmd[1], s * cmd[0] + c * cmd[1]), axis=-1)
    positions = np.empty((frames, 2))
    velocities = np.empty((frames, 2))
    accelerations = np.empty((frames, 2))
    for k in range(frames):
        p, v, a = _spring_integral(p, v, a, goals[k], y, dt)
        positions[k], velocities[k], accelerations[k] = p, v, a
    return RootTrajectory(times, positions, headings, velocities, yaw_rates, accelerations, yaw_accelerations)


def settle_trajectory(state: RootState, frames: int, cfg: SpringConfig = SpringConfig(), fps: float = FPS) -> RootTrajectory:
    """The root coming to rest from `state` (a zero command).

    Without acceleration, a stop from speed v0 ends v0 * halflife / ln2 further on
    (0.22 m from 0.5 m/s at the default halflife): what "stop" costs in distance.
    """
    return root_trajectory(state, ZERO_COMMAND, frames, cfg, fps)


def root_state_from_frames(frames: ArrayLike, fps: float = FPS, *, with_acceleration: bool = True) -> RootState:
    """The root state at the last of `frames` [K, 36] (planned or executed qpos, oldest first).

    Position and heading are the last frame's own, so the trajectory continues it
    exactly. Rates come from a least-squares polynomial fit over all K frames (degree 2,
    or 1 without acceleration or with two frames), evaluated at the last frame: with
    three frames that is the second-order backward difference, exact for constant
    acceleration; more frames average out the pelvis' gait sway, whose accelerations
    are large. One frame gives a state at rest. Headings are unwrapped before fitting.
    """
    q = np.asarray(frames, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != g1.QPOS_SIZE or len(q) < 1:
        raise RootTrajectoryError(f"frames must have shape [K >= 1, {g1.QPOS_SIZE}], got {list(q.shape)}")
    if not np.isfinite(q).all():
        raise RootTrajectoryError("frames hold NaN or infinite values; a root state needs finite frames")
    if not (math.isfinite(fps) and fps > 0):
        raise RootTrajectoryError(f"fps must be positive, got {fps!r}")
    xy = q[:, g1.QPOS_ROOT_POS][:, :2]
    yaw = np.unwrap(quat.heading(q[:, g1.QPOS_ROOT_QUAT]))
    k = len(q)
    degree = min(k - 1, 2 if with_acceleration else 1)
    rates = np.zeros((2, 3))  # rows: first and second derivative; columns: x, y, yaw
    if degree >= 1:
        t = (np.arange(k, dtype=np.float64) - (k - 1)) / fps  # the last frame at t = 0
        coeffs = np.polynomial.polynomial.polyfit(t, np.column_stack((xy, yaw)), degree)  # [degree + 1, 3]
        rates[0] = coeffs[1]
        if degree >= 2:
            rates[1] = 2.0 * coeffs[2]
    return RootState(
        position=(float(xy[-1, 0]), float(xy[-1, 1])),
        velocity=(float(rates[0, 0]), float(rates[0, 1])),
        heading=float(yaw[-1]),
        yaw_rate=float(rates[0, 2]),
        acceleration=(float(rates[1, 0]), float(rates[1, 1])),
        yaw_acceleration=float(rates[1, 2]),
    )


def no_overshoot_gain(halflife: float) -> float:
    """The largest gain (1/s) of a proportional approach through a spring of `halflife` that does not overshoot.

    Commanding k * error through the critically damped spring closes the loop
    s (s + y)^2 + k y^2 = 0, whose roots stay real while k <= 4 y / 27.
    At 0.3 s that is 0.68 1/s: `slow_radius` >= 1.46 s * `max_speed`.
    """
    if not (math.isfinite(halflife) and halflife > 0):
        raise ConfigError(f"spring halflife must be a positive number of seconds, got {halflife!r}")
    return 4.0 * _damping(halflife) / 27.0


def waypoint_command(
    state: RootState,
    target: tuple[float, float, float],
    max_speed: float,
    max_yaw_rate: float,
    slow_radius: float = 0.5,
    slow_angle: float = 0.5,
) -> VelocityCommand:
    """A go-to-pose command (heading frame) towards `target` = (x, y, heading): the `waypoints` mode.

    Walks straight at (x, y), at `max_speed` and proportionally slower inside
    `slow_radius` (m). Faces the target point when farther than twice `slow_radius`,
    the target heading inside `slow_radius`, and turns between the two in between
    (facing a point is meaningless on top of it); the yaw rate is `max_yaw_rate` times
    the heading error over `slow_angle` (rad), clamped. Asymmetric policy ranges are the
    caller's to apply (`CommandLimits.clamp`).

    Recomputed at every replan and followed through the springs, the approach overshoots
    when its gain (`max_speed / slow_radius`, `max_yaw_rate / slow_angle`) exceeds
    `no_overshoot_gain` of the springs' halflife: with the defaults and 0.3 s halflives,
    by about 5 cm at 0.6 m/s, 18 cm at 1 m/s, and 10 degrees at 1 rad/s.
    """
    for name, value, strictly in (
        ("max_speed", max_speed, False),
        ("max_yaw_rate", max_yaw_rate, False),
        ("slow_radius", slow_radius, True),
        ("slow_angle", slow_angle, True),
    ):
        if not (math.isfinite(value) and (value > 0 if strictly else value >= 0)):
            raise ConfigError(f"waypoint {name} must be {'positive' if strictly else 'non-negative'}, got {value!r}")
    tx, ty, target_heading = (float(v) for v in target)
    dx, dy = tx - state.position[0], ty - state.position[1]
    distance = math.hypot(dx, dy)
    c, s = math.cos(state.heading), math.sin(state.heading)
    vx = vy = 0.0
    if distance > 1e-9:
        speed = max_speed * min(1.0, distance / slow_radius)
        vx = speed * (c * dx + s * dy) / distance
        vy = speed * (-s * dx + c * dy) / distance
    facing_point = min(1.0, max(0.0, distance / slow_radius - 1.0))  # 0 inside slow_radius, 1 beyond twice it
    goal = target_heading
    if facing_point > 0.0:
        goal += facing_point * float(quat.wrap_angle(math.atan2(dy, dx) - target_heading))
    error = float(quat.wrap_angle(goal - state.heading))
    yaw_rate = max_yaw_rate * min(1.0, max(-1.0, error / slow_angle))
    return VelocityCommand(vx=vx, vy=vy, yaw_rate=yaw_rate)
