"""Which feet are on the ground, from the leg kinematics: the lower foot, and the other one when it is about as low.

Heights are along gravity, relative to the base (the contact points rotated by the IMU's attitude),
so no ground height is needed. A walking G1 always has a foot down, so the lower foot is always in
contact; the other one joins it within `height_margin` and leaves it above `height_margin +
hysteresis`. Measured against the simulator's contacts in docs/estimation.md, beside
a contact decision from the joint torques. Compiled: the estimator's step calls it.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True)
def decide_contacts(
    left: float, right: float, left_was: bool, right_was: bool, height_margin: float, hysteresis: float
) -> tuple[bool, bool]:
    """Whether the left and right foot touch the ground; `left`, `right`: their contact points along gravity (m, up),
    relative to the base; `left_was`, `right_was`: the last decision."""
    lowest = min(left, right)
    return (
        left - lowest < height_margin + (hysteresis if left_was else 0.0),
        right - lowest < height_margin + (hysteresis if right_was else 0.0),
    )
