"""Faults an emulator can be told to produce, changed live by tests or set from config."""

from __future__ import annotations

import random
from dataclasses import dataclass, field


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
        if self.corrupt_prob > 0 and self.rng.random() < self.corrupt_prob:
            data = bytearray(frame)
            data[self.rng.randrange(2, len(data)) if len(data) > 2 else 0] ^= 0x5A
            return bytes(data)
        return frame
