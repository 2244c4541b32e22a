"""Run-mode state machine between the command input and the policy.

RUN: the policy tracks the input's velocity. STAND: the stop button was pressed, or the
run was held (the state estimate can no longer be trusted, so nothing may walk to a
position): the policy holds a zero command. DAMP: emergency stop, a dead input, or a policy or hardware fault;
every joint is damped and the mode latches until the start button is pressed on a live
input with no fault present.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from controller.commands.velocity import ZERO, VelocityCommand
from controller.inputs.base import CommandSample


class Mode(enum.Enum):
    RUN = "run"
    STAND = "stand"
    DAMP = "damp"


@dataclass
class Supervisor:
    mode: Mode = Mode.RUN
    damp_reason: str = ""
    estops: int = 0
    input_losses: int = 0
    hold_reason: str = ""  # latched by `hold`: the start button does not resume the run

    def update(self, sample: CommandSample, fault: str | None) -> VelocityCommand:
        """Advance the mode on this input sample; returns the velocity the policy should track."""
        if fault is not None:
            self.damp(f"fault: {fault}")
        elif sample.buttons.estop:
            if self.mode is not Mode.DAMP:
                self.estops += 1
            self.damp("emergency stop pressed")
        elif not sample.alive:
            if self.mode is not Mode.DAMP:
                self.input_losses += 1
            self.damp("command input lost (stale or unplugged)")
        elif sample.buttons.start and not self.hold_reason:
            self.mode, self.damp_reason = Mode.RUN, ""
        elif sample.buttons.stop and self.mode is Mode.RUN:
            self.mode = Mode.STAND
        return sample.velocity if self.mode is Mode.RUN else ZERO

    def hold(self, reason: str) -> None:
        """Stand for good (kept when damping: that is safer still); the first cause is the one reported."""
        if not self.hold_reason:
            self.hold_reason = reason
        if self.mode is Mode.RUN:
            self.mode = Mode.STAND

    def damp(self, reason: str) -> None:
        """Enter damping for `reason` (kept when already damping: the first cause is the one to fix)."""
        if self.mode is not Mode.DAMP:
            self.damp_reason = reason
        self.mode = Mode.DAMP
