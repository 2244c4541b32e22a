"""Feedback of every motor of a robot (motor side): what the 500 Hz cycle fills and the safety checks read.

Drivers write RS-485 replies straight into the `FeedbackStore`; CAN replies go through the
`MitReplyBank`, which decodes a cycle's replies in one pass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hw.protocols import mit


@dataclass(frozen=True)
class MotorFeedback:
    """Newest reply of one motor (motor side); `stamp` is None until the first reply."""

    position: float
    velocity: float
    torque: float
    temperature: float | None
    error_code: int
    error: str
    faulted: bool
    stamp: float | None
    missed: int


class FeedbackStore:
    """Newest motor-side feedback of every motor of a robot, in robot joint order.

    The safety checks read whole arrays at once; `feedback(j)` spells one motor out."""

    def __init__(self, n: int) -> None:
        self.position = np.zeros(n)
        self.velocity = np.zeros(n)
        self.torque = np.zeros(n)
        self.temperature = np.full(n, np.nan)
        self.error_code = np.full(n, -1, dtype=np.int64)  # -1 until a reply: its first code is always named
        self.faulted = np.zeros(n, dtype=bool)
        self.stamp = np.full(n, np.nan)
        self.missed = np.zeros(n, dtype=np.int64)
        self.error = ["no reply"] * n

    def feedback(self, j: int) -> MotorFeedback:
        temp, stamp = float(self.temperature[j]), float(self.stamp[j])
        return MotorFeedback(
            float(self.position[j]),
            float(self.velocity[j]),
            float(self.torque[j]),
            None if math.isnan(temp) else temp,
            int(self.error_code[j]),
            self.error[j],
            bool(self.faulted[j]),
            None if math.isnan(stamp) else stamp,
            int(self.missed[j]),
        )


class MitReplyBank:
    """Newest reply of every MIT motor of a robot, one row each (robot MIT order).

    Drivers append each healthy reply to `pending` as it arrives (to `late` when it missed
    its cycle's deadline); `publish` decodes them once per cycle in one plain loop (for a
    robot's few dozen motors that costs less than a chain of small array operations, whose
    fixed cost dominates with cold caches) and moves the rows into the feedback store in a
    few array writes.
    """

    def __init__(self, joint_index: list[int], ranges: list[mit.MitRanges], variants: list[str]) -> None:
        m = len(joint_index)
        self.joints = np.array(joint_index, dtype=np.int64)
        self.pending: list[tuple[int, bytes | bytearray]] = []  # (row, 6- or 8-byte reply), length already checked
        self.late: list[tuple[int, bytes | bytearray]] = []  # replies after their deadline: values, but no stamp
        self._scales = [mit.reply_scales(r) for r in ranges]
        self._kinds = [mit.REPLY_VARIANTS.index(v) for v in variants]  # 0 basic, 1 cubemars, 2 damiao
        # Rows that never replied keep the store's initial values.
        self._position, self._velocity, self._torque = [0.0] * m, [0.0] * m, [0.0] * m
        self._temperature = [math.nan] * m
        self._code = [-1] * m

    def publish(self, store: FeedbackStore, now: float) -> None:
        """Decode the pending replies into their rows and the rows into the store; rows that
        replied are stamped `now`."""
        pending, late = self.pending, self.late
        if not pending and not late:
            return
        scales, kinds, codes, temperature = self._scales, self._kinds, self._code, self._temperature
        position, velocity, torque = self._position, self._velocity, self._torque
        changed = []
        for row, data in (late + pending) if late else pending:  # in arrival order: the newest wins
            word = int.from_bytes(data, "big") << (64 - 8 * len(data))
            position[row], velocity[row], torque[row] = mit.reply_values(word, scales[row])
            kind = kinds[row]
            if kind == 1:  # CubeMars: int8 temperature in byte 6, error code in byte 7
                t = (word >> 8) & 0xFF
                temperature[row], code = t - 256 if t > 127 else t, word & 0xFF
            elif kind == 2:  # Damiao: rotor temperature in byte 7, state in the high nibble of byte 0
                temperature[row], code = word & 0xFF, word >> 60
            else:
                code = 0  # no error field: a reply means ok
            if code != codes[row]:
                codes[row] = code
                changed.append(row)
        js = self.joints
        store.position[js], store.velocity[js], store.torque[js], store.temperature[js] = position, velocity, torque, temperature
        rows = {row for row, _ in pending}  # a row can reply twice in a cycle (another host's command)
        stamped = js if len(rows) == len(js) else js[sorted(rows)]
        store.stamp[stamped] = now
        store.missed[stamped] = 0
        pending.clear()
        late.clear()
        for row in changed:  # rarely: look the new code's name up
            self._name_code(store, int(js[row]), kinds[row], codes[row])

    @staticmethod
    def _name_code(store: FeedbackStore, j: int, kind: int, code: int) -> None:
        store.error_code[j] = code
        if kind == 2:
            store.error[j], store.faulted[j] = mit.DAMIAO_STATES.get(code, f"unknown state {code:#x}"), code not in mit.DAMIAO_HEALTHY
        else:
            store.error[j], store.faulted[j] = mit.CUBEMARS_ERRORS.get(code, f"unknown error {code}"), code != 0
