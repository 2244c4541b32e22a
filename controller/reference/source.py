"""Where a run's reference comes from: the command itself, or the planner in the loop.

The session asks its source for the window of each tick; it never knows which one runs.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, Any

from controller.commands.velocity import VelocityCommand
from controller.reference.window import ReferenceWindow
from hw.types import RobotState

if TYPE_CHECKING:
    from controller.reference.waypoints import Follower


class ReferenceSource(abc.ABC):
    needs_base_position = False  # True: it walks to positions (waypoints, re-anchored plans), so it stands when the estimate fails
    follower: Follower | None = None  # the waypoints (or curve) it walks to, if any (their errors are judged by the truth too)

    def start(self, state: RobotState) -> None:  # noqa: B027 - optional: most sources need no starting pose
        """The run begins with the robot in `state`."""

    @abc.abstractmethod
    def window(self, state: RobotState, velocity: VelocityCommand, gesture: str = "", hold: bool = False) -> ReferenceWindow:
        """The reference of this tick, given the robot's state, the supervised velocity command and the gesture asked for.

        `hold`: the supervisor stands or damps the robot: no mode may move it (waypoints wait).
        """

    def report(self) -> dict[str, Any]:
        """Counters for the run report."""
        return {}

    def close(self) -> None:  # noqa: B027 - optional: most sources hold nothing
        """Release workers; safe twice."""


class CommandReference(ReferenceSource):
    """The velocity command itself is the reference (the velocity tracker's own input)."""

    def window(self, state: RobotState, velocity: VelocityCommand, gesture: str = "", hold: bool = False) -> ReferenceWindow:
        return ReferenceWindow(state.time, velocity)  # gestures need the planner; a held robot already has a zero command
