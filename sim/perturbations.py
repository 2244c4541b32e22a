"""Perturbations of a simulated run, each typed and seeded: what a robustness sweep varies.

- The world and the body (`apply_to_model`, once, before the run): friction, a payload on the
  torso, motor strength (effort limits scaled); uneven ground is built into the scene itself
  (`sim.world.SceneConfig`, bumps seeded from the run's seed).
- Pushes (`PushSchedule`): a horizontal force on the pelvis for `duration_s`, every
  `interval_s` from `start_s`, in a seeded direction; the impulse is force times duration.
- What the controller sees and sends (`PerturbedRobot`, a wrapper of the robot interface):
  joint and gyro noise, an IMU tilt bias, dropped sensor packets (the previous reading
  again), whole control ticks of latency between the observation and the command, and the
  PD gains scaled (the other half of motor strength).

Any value of a perturbation set may be a range `[low, high]` instead (`draw_perturbations`): each
run draws it from its seed (whole numbers for whole-number fields), so a condition can randomize
rather than fix a level. The same seed gives the same perturbations: every random draw comes
from one generator per run, the ranges from one of their own.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import typing
from dataclasses import dataclass, replace
from typing import Any

import mujoco
import numpy as np

from hw import g1, quat
from hw.errors import ConfigError
from hw.robot import RobotInterface
from hw.shipped import config_dir
from hw.types import JointCommand, RobotState
from hw.yamlconfig import from_dict, load_yaml, resolve_preset
from sim.robot import SimRobot


@dataclass(frozen=True)
class Pushes:
    force_n: float  # horizontal force on the pelvis
    duration_s: float = 0.1
    interval_s: float = 4.0  # from the start of one push to the next
    start_s: float = 2.0  # the first push, after the run starts
    direction_deg: float | None = None  # heading of the force in the world frame; None: a seeded draw per push

    def __post_init__(self) -> None:
        if self.force_n < 0 or self.duration_s <= 0 or self.interval_s <= self.duration_s or self.start_s < 0:
            raise ConfigError("pushes need force_n >= 0, duration_s > 0, interval_s > duration_s and start_s >= 0")

    @property
    def impulse_ns(self) -> float:
        return self.force_n * self.duration_s


@dataclass(frozen=True)
class Perturbations:
    pushes: Pushes | None = None
    friction_scale: float = 1.0  # sliding friction between the feet and the floor, scaled
    payload_kg: float = 0.0  # extra mass on the torso
    torque_scale: float = 1.0  # motor strength: every joint's effort limit, scaled
    gain_scale: float = 1.0  # motor strength: the PD gains the controller sends, scaled
    latency_ticks: int = 0  # whole control ticks between the observation and the command
    joint_noise_rad: float = 0.0  # Gaussian noise on joint positions (velocities get 10 times it, per second)
    gyro_noise_rad_s: float = 0.0
    imu_tilt_bias_deg: float = 0.0  # a fixed tilt of the IMU's attitude, in a seeded direction
    drop_rate: float = 0.0  # the share of sensor readings lost (the previous one is seen again)
    terrain_height_m: float = 0.0  # uneven ground: seeded bumps up to this high (the scene is built with them, `sim.world`)

    def __post_init__(self) -> None:
        checks = {
            "friction_scale": self.friction_scale > 0, "torque_scale": self.torque_scale > 0, "gain_scale": self.gain_scale > 0,
            "payload_kg": self.payload_kg >= 0, "latency_ticks": self.latency_ticks >= 0, "joint_noise_rad": self.joint_noise_rad >= 0,
            "gyro_noise_rad_s": self.gyro_noise_rad_s >= 0, "drop_rate": 0.0 <= self.drop_rate < 1.0,
            "terrain_height_m": 0.0 <= self.terrain_height_m <= 0.3,
        }  # fmt: skip
        bad = [name for name, ok in checks.items() if not ok]
        if bad:
            raise ConfigError(f"perturbations out of range: {', '.join(bad)} (scales > 0, amounts >= 0, drop_rate in [0, 1))")

    @property
    def senses(self) -> bool:
        """Whether anything between the robot and the controller is perturbed (`PerturbedRobot` is needed)."""
        return bool(
            self.gain_scale != 1.0 or self.latency_ticks or self.joint_noise_rad or self.gyro_noise_rad_s
            or self.imu_tilt_bias_deg or self.drop_rate
        )  # fmt: skip


def apply_to_model(model: mujoco.MjModel, p: Perturbations) -> None:
    """Friction, payload and effort limits into a freshly compiled G1 scene."""
    # Sliding friction, both ways a contact gets it: the G1 MJCF pairs each foot capsule with the floor explicitly
    # (`<contact><pair>`), and such a contact takes the pair's own friction (both tangential directions), not its geoms';
    # any other contact takes the larger of its two geoms' frictions.
    model.geom_friction[:, 0] *= p.friction_scale
    model.pair_friction[:, :2] *= p.friction_scale
    model.body_mass[model.body(g1.TORSO_BODY).id] += p.payload_kg
    model.actuator_forcerange[:] *= p.torque_scale


@dataclass(frozen=True)
class Push:
    start: float
    end: float
    force: tuple[float, float, float]  # world frame, N


def push_schedule(p: Pushes | None, duration_s: float, rng: np.random.Generator) -> tuple[Push, ...]:
    """Every push of a run of `duration_s`, directions drawn from `rng` when not fixed."""
    if p is None or p.force_n == 0:
        return ()
    pushes = []
    t = p.start_s
    while t + p.duration_s <= duration_s:
        heading = math.radians(p.direction_deg) if p.direction_deg is not None else float(rng.uniform(0.0, 2.0 * math.pi))
        pushes.append(Push(t, t + p.duration_s, (p.force_n * math.cos(heading), p.force_n * math.sin(heading), 0.0)))
        t += p.interval_s
    return tuple(pushes)


class PushForces:
    """A run's pushes on the simulated robot's pelvis: `apply()` sets the force in effect at the physics' time."""

    def __init__(self, robot: SimRobot, pushes: tuple[Push, ...]) -> None:
        self.robot, self.pushes = robot, pushes
        self._pelvis = robot.model.body(g1.ROOT_BODY).id

    def boundaries(self, start: float, end: float) -> list[float]:
        """Times in (start, end) where a push begins or ends: the physics must stop there to switch the force."""
        return sorted(b for push in self.pushes for b in (push.start, push.end) if start < b < end)

    def apply(self) -> None:
        now = self.robot.time
        active = next((push for push in self.pushes if push.start <= now < push.end), None)
        self.robot.data.xfrc_applied[self._pelvis, :3] = active.force if active is not None else (0.0, 0.0, 0.0)


class PerturbedRobot(RobotInterface):
    """A robot seen and commanded through the sensing and actuation perturbations (`Perturbations.senses`)."""

    def __init__(self, robot: RobotInterface, p: Perturbations, rng: np.random.Generator) -> None:
        super().__init__()
        self.robot, self.p, self.rng = robot, p, rng
        self._pending: collections.deque[JointCommand] = collections.deque()
        self._last: RobotState | None = None
        axis = rng.uniform(0.0, 2.0 * math.pi)
        self._tilt = quat.from_axis_angle(np.array([math.cos(axis), math.sin(axis), 0.0]), math.radians(p.imu_tilt_bias_deg))

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.robot.joint_names

    def read(self) -> RobotState:
        state = self.robot.read()
        p, rng = self.p, self.rng
        if self._last is not None and p.drop_rate and rng.random() < p.drop_rate:
            return self._last
        n = len(state.joint_pos)
        if p.joint_noise_rad:
            state = replace(
                state,
                joint_pos=state.joint_pos + rng.normal(0.0, p.joint_noise_rad, n),
                joint_vel=state.joint_vel + rng.normal(0.0, 10 * p.joint_noise_rad, n),
            )
        if p.gyro_noise_rad_s:
            state = replace(state, base_ang_vel=state.base_ang_vel + rng.normal(0.0, p.gyro_noise_rad_s, 3))
        if p.imu_tilt_bias_deg:
            state = replace(state, base_quat=quat.multiply(state.base_quat, self._tilt))
        self._last = state
        return state

    def write(self, command: JointCommand) -> None:
        if self.p.gain_scale != 1.0:
            command = replace(command, kp=command.kp * self.p.gain_scale, kd=command.kd * self.p.gain_scale)
        self._pending.append(command)
        while len(self._pending) > self.p.latency_ticks:
            self.robot.write(self._pending.popleft())

    def damp(self) -> None:
        self._pending.clear()
        self.robot.damp()


RANGE_STREAM = 0x5EED  # the ranges' generator: (seed, this), apart from the run's own draws


def has_ranges(values: Any) -> bool:
    """Whether a perturbation set's values (a YAML mapping) hold a `[low, high]` range anywhere."""
    if not isinstance(values, dict):
        return False
    return any(_is_range(v) or has_ranges(v) for v in values.values())


def draw_perturbations(values: Any, seed: int, source: str, key: str = "") -> Perturbations:
    """The perturbations of one run: every `[low, high]` in `values` drawn from `seed`; mistakes name the file and key."""
    rng = np.random.default_rng([seed, RANGE_STREAM])
    return from_dict(Perturbations, _draw(Perturbations, values or {}, rng, source, key), source, key)


def _is_range(value: Any) -> bool:
    return isinstance(value, list) and len(value) == 2 and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)


def _draw(cls: type, values: Any, rng: np.random.Generator, source: str, key: str) -> Any:
    if not isinstance(values, dict):
        return values  # from_dict says what is wrong with it
    hints = typing.get_type_hints(cls)
    drawn = {}
    for name, value in values.items():
        where = f"{key}.{name}" if key else name
        nested = [t for t in typing.get_args(hints.get(name)) if isinstance(t, type) and dataclasses.is_dataclass(t)]
        if nested and isinstance(value, dict):
            drawn[name] = _draw(nested[0], value, rng, source, where)
        elif _is_range(value):
            low, high = value
            if low > high:
                raise ConfigError(f"{source}: {where}: a range is [low, high] with low <= high, got {value}")
            whole = hints.get(name) is int
            drawn[name] = int(rng.integers(low, high + 1)) if whole else float(rng.uniform(low, high))
        else:
            drawn[name] = value
    return drawn


def load_perturbations(name_or_path: str, seed: int = 0) -> Perturbations:
    """A shipped perturbation set by name (`configs/perturbations/`) or a YAML file, its ranges drawn from `seed`;
    mistakes name the file and key."""
    path = resolve_preset(name_or_path, config_dir("perturbations"), "perturbation set")
    return draw_perturbations(load_yaml(path), seed, str(path))


def perturbation_values(name_or_path: str) -> Any:
    """A perturbation set's YAML values as written (ranges undrawn)."""
    return load_yaml(resolve_preset(name_or_path, config_dir("perturbations"), "perturbation set"))
