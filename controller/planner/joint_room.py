"""Joint limits in the planner's output space: a correction never takes a joint past its limit.

The plan is a base (the anchor curve, or the plan before foot locking) plus a correction (the
learned residual, or the foot lock's inverse kinematics). Each joint's correction is mapped
onto the room the base leaves towards the limit it heads for, as room * tanh(correction /
room): the same where it is small against the room, and never reaching the limit however
large. Clamping afterwards instead flattened 80,733 joint values in 300 s of random commands
(2026-12-02), and a flat stretch at a limit is a velocity step for the tracker. Keyframes stay
exact, since the correction is zero there. Pure numpy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def within_room(base: FloatArray, correction: FloatArray, lower: FloatArray, upper: FloatArray) -> FloatArray:
    """`base + correction` with each correction squashed into the room `base` leaves to `lower` or `upper` (broadcast on
    the last axis, one per joint). A base already past a limit keeps its value and takes no correction towards it."""
    room = np.where(correction > 0, upper - base, base - lower)
    open_room = room > 0
    safe = np.where(open_room, room, 1.0)
    out = base + np.where(open_room, safe * np.tanh(correction / safe), 0.0)
    return np.minimum(np.maximum(out, np.minimum(base, lower)), np.maximum(base, upper))  # the last bit of rounding only
