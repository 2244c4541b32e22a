"""The tracker interface: robot state plus a reference window in, joint command out.

The run loop calls `step` at `rate_hz` and writes what it returns; it never looks inside.
A tracker that can no longer produce safe commands latches `latched_fault` and from then
on returns its damping command, so the session damps the robot and reports why.
"""

from __future__ import annotations

import abc

from controller.commands.velocity import CommandLimits
from controller.reference.window import ReferenceWindow
from hw.types import JointCommand, RobotState


class Tracker(abc.ABC):
    name: str  # registry name, for reports
    rate_hz: float  # how often `step` must be called
    joint_names: tuple[str, ...]  # order of the joint arrays of every command it returns
    command_limits: CommandLimits  # the velocities it can follow: inputs scale their sticks to these
    needs_plan: bool = False  # it follows planned frames: a run without the planner is refused before it starts

    @property
    @abc.abstractmethod
    def latched_fault(self) -> str | None:
        """Set when it stopped producing safe commands (the run damps)."""

    @property
    @abc.abstractmethod
    def nonfinite_events(self) -> int:
        """Non-finite outputs it caught (counted in the report)."""

    @abc.abstractmethod
    def step(self, state: RobotState, reference: ReferenceWindow) -> JointCommand:
        """The joint command for this tick."""

    @abc.abstractmethod
    def damping_command(self) -> JointCommand:
        """Zero stiffness, damping only, in this tracker's joint order: the safe state."""

    @abc.abstractmethod
    def reset(self) -> None:
        """Forget history (after the robot was stood up again); clears a latched fault."""
