"""Which feet are on the ground, from the leg kinematics: the lower foot, and the other one when it is about as low.

Heights are along gravity, relative to the base (the contact points rotated by the IMU's attitude),
so no ground height is needed. A walking G1 always has a foot down, so the lower foot is always in
contact; the other one joins it within `height_margin` and leaves it above `height_margin +
hysteresis`. Measured against the simulator's contacts in docs/estimation.md, beside
a contact decision from the joint torques.
"""

from __future__ import annotations

from controller.estimation.config import ContactConfig


class ContactDetector:
    def __init__(self, config: ContactConfig) -> None:
        self.config = config
        self.contacts = (True, True)

    def reset(self) -> None:
        self.contacts = (True, True)

    def decide(self, left: float, right: float) -> tuple[bool, bool]:
        """`left`, `right`: the feet's contact points along gravity (m, up), relative to the base."""
        lowest = min(left, right)
        margin, extra = self.config.height_margin, self.config.hysteresis
        self.contacts = (
            left - lowest < margin + (extra if self.contacts[0] else 0.0),
            right - lowest < margin + (extra if self.contacts[1] else 0.0),
        )
        return self.contacts
