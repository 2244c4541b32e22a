"""The state estimator's settings: frozen typed dataclasses, values in `configs/estimator.yaml`.

Every value is checked on load; a mistake is one line naming the file, the key, the value and
what is allowed (`hw.yamlconfig` adds the file and the section, `__post_init__` the rest).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

from hw.shipped import config_dir
from hw.yamlconfig import load_config


def _check_positive(section: object) -> None:
    """Every number of a section must be finite and > 0."""
    for field in dataclasses.fields(section):  # type: ignore[arg-type]
        value = getattr(section, field.name)
        if isinstance(value, float) and not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{field.name}: {value!r} is not allowed, it must be a number > 0")


@dataclass(frozen=True)
class ProcessNoise:
    """How far the prediction is trusted, per second of it (standard deviations)."""

    accel: float  # m/s^2: the IMU's acceleration error (white), what the base velocity may wander by
    position: float  # m/sqrt(s): the base position's own random walk beyond its velocity
    stance_foot: float  # m/sqrt(s): how much a standing foot may creep (rolling, small slips)
    swing_foot: float  # m/sqrt(s): a foot in the air is free: large, so its position is re-taken at touchdown

    def __post_init__(self) -> None:
        _check_positive(self)


@dataclass(frozen=True)
class MeasurementNoise:
    """How far each leg-kinematic measurement is trusted (standard deviations)."""

    foot_position: float  # m: a foot's position relative to the base, from the joint encoders
    foot_velocity: float  # m/s: the base velocity a standing foot implies, -R (J dq + w x r), for the lower standing foot
    # m: a standing foot's velocity noise grows as (1 + h / height_scale), h its height above the lower standing foot (a
    # landing foot is none: contact.settle_time): a foot that rolls onto its toe or heel moves at its sole point while it
    # still touches the floor.
    height_scale: float

    def __post_init__(self) -> None:
        _check_positive(self)


@dataclass(frozen=True)
class ContactConfig:
    """A foot is in contact when it is the lower foot, or within `height_margin` of the lower one (heights along gravity).

    A foot that has just come into contact is still landing: its impact slides it on (on the simulator, from about
    0.9 m/s to rest in 15 ms, 2-3 mm forward). For `settle_time` after it joined, neither its velocity nor its position
    counts; the other foot and the IMU carry the estimate.
    """

    height_margin: float  # m
    hysteresis: float  # m: a foot in contact leaves it only `height_margin + hysteresis` above the lower foot
    settle_time: float  # s

    def __post_init__(self) -> None:
        _check_positive(self)


@dataclass(frozen=True)
class FaultConfig:
    """When the estimate can no longer be trusted: the fault latches until `reset()`."""

    max_position_std: float  # m: the base position's standard deviation beyond which the filter has diverged
    slip_speed: float  # m/s: flat feet sliding apart, filtered
    # the lower foot's horizontal velocity innovation squared over its variance, filtered (chi-square, 2 degrees of freedom)
    slip_chi2: float
    flat_height: float  # m: a foot this close above the lower one is flat on the ground, for the slip watch
    slip_time_constant: float  # s: the low-pass filter on both slip measures (touchdown transients pass through it)
    max_gap: float  # s: the longest time between two updates

    def __post_init__(self) -> None:
        _check_positive(self)


@dataclass(frozen=True)
class EstimatorConfig:
    process: ProcessNoise
    measurement: MeasurementNoise
    contact: ContactConfig
    fault: FaultConfig
    gravity: float = 9.81  # m/s^2: what the accelerometer reads at rest, up

    def __post_init__(self) -> None:
        _check_positive(self)


def default_estimator_config_path() -> Path:
    return config_dir() / "estimator.yaml"


def load_estimator_config(path: str | Path | None = None) -> EstimatorConfig:
    """The estimator's settings from `path` (default: the shipped `configs/estimator.yaml`), checked."""
    return load_config(EstimatorConfig, Path(path) if path is not None else default_estimator_config_path())
