"""What a run drives: a robot to read and write, and the time line it runs on.

The session never knows which backend it has: MuJoCo directly, simulated hardware with
MuJoCo behind the buses, or real hardware. A backend moves its own time to the control
loop's deadlines (physics steps, or bus cycles paced on the wall clock).
"""

from __future__ import annotations

import abc
from types import TracebackType
from typing import Any, Self

from hw.robot import RobotInterface
from hw.types import RobotState


class Backend(abc.ABC):
    robot: RobotInterface  # what the controller reads and writes
    paced_on_wall_clock = False  # True: `advance_to` waits for the wall clock itself (a robot that runs on its own)
    measures_base_position = False  # True: the robot's state carries the base position and velocity (the simulator's)

    def start(self) -> None:  # noqa: B027 - optional: most backends are ready once built
        """Bring the robot up (hardware: configure, soft start); a fault here ends the run like any other."""

    @abc.abstractmethod
    def now(self) -> float:
        """Seconds on the run's time line."""

    @abc.abstractmethod
    def advance_to(self, t: float) -> None:
        """Run the robot side (physics, bus cycles) until time `t`."""

    def truth(self) -> RobotState | None:
        """Ground truth where a simulator stands behind a robot that is not itself (for metrics); None where the robot's
        own state is the truth (the simulator read directly: the session reads it there when an estimator runs) or
        there is no simulator."""
        return None

    def truth_contacts(self) -> tuple[bool, bool] | None:
        """The simulator's foot contacts (left, right), to judge an estimator's; None without a simulator."""
        return None

    def has_fallen(self) -> bool:
        return False

    def recover_from_fall(self) -> bool:
        """Stand the robot up again; False when that cannot be done by software (the run ends)."""
        return False

    def fault(self) -> str | None:
        """A latched fault of the robot side, or None."""
        return None

    def report(self) -> dict[str, Any] | None:
        """Counters for the run report (hardware: bus counters); None when there is nothing to add."""
        return None

    @abc.abstractmethod
    def close(self) -> None:
        """Damp and release everything; safe to call twice."""

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()
