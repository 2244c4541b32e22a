"""Faults an emulator can be told to produce, changed live by tests or set from config."""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from pathlib import Path

from hw.errors import ConfigError
from hw.yamlconfig import load_config


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
    seed: int = 0
    rng: random.Random = field(init=False)

    def __post_init__(self) -> None:
        self.rng = random.Random(self.seed)

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
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("drop_reply_prob", "corrupt_prob"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be within [0, 1], got {getattr(self, name)}")
        if self.delay_reply_s < 0:
            raise ValueError(f"delay_reply_s must be >= 0, got {self.delay_reply_s}")

    def plan(self) -> FaultPlan:
        return FaultPlan(
            drop_reply_prob=self.drop_reply_prob,
            delay_reply_s=self.delay_reply_s,
            corrupt_prob=self.corrupt_prob,
            error_codes=dict(self.error_codes),
            over_temperature=set(self.over_temperature),
            stuck=set(self.stuck),
            bus_off=self.bus_off,
            silent=self.silent,
            seed=self.seed,
        )


@dataclass(frozen=True)
class FaultFile:
    """Faults per bus name, injected into simulated hardware (`g1ctl sim --hardware X --faults FILE`)."""

    buses: dict[str, FaultSpec]


def load_faults(path: str, bus_names: list[str]) -> dict[str, FaultPlan]:
    spec = load_config(FaultFile, Path(path))
    unknown = [b for b in spec.buses if b not in bus_names]
    if unknown:
        raise ConfigError(f"{path}: buses {unknown} are not in the hardware config (buses: {', '.join(bus_names)})")
    return {bus: s.plan() for bus, s in spec.buses.items()}
