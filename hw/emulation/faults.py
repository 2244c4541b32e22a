"""Faults an emulator can be told to produce, changed live by tests or set from a fault plan.

A fault plan (`configs/faults/*.yaml`, `g1ctl sim --hardware X --faults PLAN`) is a drill: what
goes wrong on which bus (or in the controller's own commands, or in a simulated G1 over DDS),
from when, and what the stack must do about it (`DrillExpectation`): damp every motor within a
stated time, ride through, or clamp. The run's report says whether it did (`hw.drill`).
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field, fields, replace
from typing import Literal

from hw.emulation.g1_faults import RobotFault
from hw.emulation.imu_model import ZERO, ImuBias, Vec3
from hw.errors import ConfigError
from hw.shipped import config_dir
from hw.yamlconfig import load_config, preset_names, resolve_preset


@dataclass
class FaultPlan:
    drop_reply_prob: float = 0.0  # each reply is lost with this probability
    delay_reply_s: float = 0.0  # wall-clock delay before each reply
    corrupt_prob: float = 0.0  # one byte of a reply is flipped with this probability
    error_codes: dict[int, int] = field(default_factory=dict)  # motor id -> error code to raise (latched)
    over_temperature: set[int] = field(default_factory=set)  # motor ids whose winding overheats now
    stuck: set[int] = field(default_factory=set)  # motor ids whose output is seized
    bus_off: bool = False  # the bus goes silent after one error frame
    silent: bool = False  # IMU: stop sending frames
    gyro_bias: Vec3 = ZERO  # IMU: rad/s added to every gyro sample (and so to the heading's drift)
    accel_bias: Vec3 = ZERO  # IMU: m/s^2 added to every accelerometer sample
    seed: int = 0
    start_s: float = 0.0  # simulated time from which `pending` is in force
    pending: FaultSpec | None = None  # faults held back until `update` reaches start_s
    rng: random.Random = field(init=False)

    def __post_init__(self) -> None:
        self.rng = random.Random(self.seed)

    def update(self, now: float) -> None:
        """Switch the held-back faults on once simulated time reaches `start_s`."""
        spec = self.pending
        if spec is not None and now >= self.start_s:
            self.pending = None
            live = spec.plan(held_back=False)
            for f in fields(self):
                if f.init and f.name not in ("seed", "start_s", "pending"):
                    setattr(self, f.name, getattr(live, f.name))

    @property
    def imu_bias(self) -> ImuBias:
        return ImuBias(self.gyro_bias, self.accel_bias)

    def drop(self) -> bool:
        return self.drop_reply_prob > 0 and self.rng.random() < self.drop_reply_prob

    def corrupt(self, frame: bytes) -> bytes:
        """The frame with one byte flipped, with probability `corrupt_prob` (else unchanged)."""
        if self.corrupt_prob > 0 and self.rng.random() < self.corrupt_prob:
            data = bytearray(frame)
            data[self.rng.randrange(2, len(data)) if len(data) > 2 else 0] ^= 0x5A
            return bytes(data)
        return frame


@dataclass(frozen=True)
class FaultSpec:
    """The YAML form of a `FaultPlan` for one bus (see `configs/faults/`)."""

    drop_reply_prob: float = 0.0
    delay_reply_s: float = 0.0
    corrupt_prob: float = 0.0
    error_codes: dict[int, int] = field(default_factory=dict)
    over_temperature: tuple[int, ...] = ()
    stuck: tuple[int, ...] = ()
    bus_off: bool = False
    silent: bool = False
    gyro_bias: Vec3 = ZERO  # the IMU's bus only: rad/s, IMU frame
    accel_bias: Vec3 = ZERO  # the IMU's bus only: m/s^2, IMU frame
    seed: int = 0
    start_s: float = 0.0  # simulated seconds from the start of the run

    def __post_init__(self) -> None:
        for name in ("drop_reply_prob", "corrupt_prob"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be within [0, 1], got {getattr(self, name)}")
        if self.delay_reply_s < 0 or self.start_s < 0:
            raise ValueError("delay_reply_s and start_s must be >= 0")
        if not all(math.isfinite(v) for v in (*self.gyro_bias, *self.accel_bias)):
            raise ValueError(f"gyro_bias and accel_bias must be finite, got {list(self.gyro_bias)} and {list(self.accel_bias)}")

    @property
    def biases_imu(self) -> bool:
        return self.gyro_bias != ZERO or self.accel_bias != ZERO

    @property
    def starts_fault(self) -> bool:
        """True when this spec makes something go wrong (not only seeds a bus)."""
        return replace(self, seed=0, start_s=0.0) != FaultSpec()

    def plan(self, held_back: bool = True) -> FaultPlan:
        """The live plan; with a `start_s`, nominal (only seeded) until its `update` reaches that time."""
        if held_back and self.start_s > 0:
            return FaultPlan(seed=self.seed, start_s=self.start_s, pending=self)
        return FaultPlan(
            drop_reply_prob=self.drop_reply_prob,
            delay_reply_s=self.delay_reply_s,
            corrupt_prob=self.corrupt_prob,
            error_codes=dict(self.error_codes),
            over_temperature=set(self.over_temperature),
            stuck=set(self.stuck),
            bus_off=self.bus_off,
            silent=self.silent,
            gyro_bias=self.gyro_bias,
            accel_bias=self.accel_bias,
            seed=self.seed,
        )


@dataclass(frozen=True)
class HostFaults:
    """Faults of the controller itself, on the host side of the safety layer: the commands it writes go bad."""

    nan_command_s: float | None = None  # from this time on, every command the controller writes is NaN
    wild_command_s: float | None = None  # from this time on, commands far outside every limit (10 rad, 1000 rad/s, 10 kN m)

    @property
    def start_s(self) -> float | None:
        times = [t for t in (self.nan_command_s, self.wild_command_s) if t is not None]
        return min(times) if times else None


@dataclass(frozen=True)
class DrillExpectation:
    """What the stack must do about the plan's faults; checked on what the emulated motors decoded from the frames."""

    outcome: Literal["damping", "ride-through", "clamped"] = "damping"
    within_s: float = 0.1  # damping: every motor safe (damped, or limp on its own watchdog or error) this soon after the fault
    names: str = ""  # damping: the latched fault names this (a joint, a bus, "IMU", "non-finite", ...)

    def __post_init__(self) -> None:
        if self.within_s <= 0:
            raise ValueError(f"within_s must be positive, got {self.within_s}")


@dataclass(frozen=True)
class FaultFile:
    """A drill: faults per bus name, in the controller's commands, or in a simulated G1 over DDS, and what must follow."""

    hardware: str = "sim-can"  # the hardware config the plan is written for (its bus names)
    description: str = ""
    buses: dict[str, FaultSpec] = field(default_factory=dict)
    host: HostFaults = field(default_factory=HostFaults)
    robot: tuple[str, ...] = ()  # a simulated G1 over DDS: `KIND@SECONDS` faults (hw.emulation.g1_faults)
    expect: DrillExpectation = field(default_factory=DrillExpectation)

    def __post_init__(self) -> None:
        for text in self.robot:
            RobotFault.parse(text)  # one line naming the kinds when it is wrong

    @property
    def start_s(self) -> float | None:
        """When the first fault of the plan strikes (None: the plan has none, only seeds)."""
        times = [s.start_s for s in self.buses.values() if s.starts_fault]
        times += [RobotFault.parse(text).at_s for text in self.robot]
        if self.host.start_s is not None:
            times.append(self.host.start_s)
        return min(times) if times else None


def available_fault_plans() -> list[str]:
    return preset_names(config_dir("faults"))


def load_fault_file(name_or_path: str) -> FaultFile:
    """A shipped plan by name (`configs/faults/`) or a YAML file by path."""
    return load_config(FaultFile, resolve_preset(name_or_path, config_dir("faults"), "fault plan"))


def load_faults(plan: FaultFile, source: str, bus_names: list[str], imu_bus: str | None = None) -> dict[str, FaultPlan]:
    """The live plan per bus; a bus the hardware config lacks, or an IMU bias on a bus that is not the IMU's, is named in one line."""
    unknown = [b for b in plan.buses if b not in bus_names]
    if unknown:
        raise ConfigError(f"{source}: buses {unknown} are not in the hardware config (buses: {', '.join(bus_names)})")
    misplaced = [b for b, s in plan.buses.items() if s.biases_imu and b != imu_bus]
    if misplaced:
        where = f"the IMU is on bus '{imu_bus}'" if imu_bus else "this hardware config has no IMU"
        raise ConfigError(f"{source}: buses.{misplaced[0]}: gyro_bias and accel_bias are faults of the IMU; {where}")
    return {bus: s.plan() for bus, s in plan.buses.items()}


def check_plan_fits(plan: FaultFile, source: str, dds: bool) -> None:
    """Bus faults need simulated buses, `robot:` faults a simulated G1 over DDS: one line when they do not fit."""
    if dds and plan.buses:
        raise ConfigError(f"{source}: a DDS config has no buses to fault; give the simulated G1's faults under 'robot:' (e.g. [stale@3])")
    if not dds and plan.robot:
        raise ConfigError(f"{source}: 'robot:' faults are for a simulated G1 over DDS (--hardware sim-dds); this config has buses")
