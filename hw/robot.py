"""The robot interface every backend implements (MuJoCo simulation, real or simulated buses)."""

from __future__ import annotations

import abc
import enum
import warnings
from types import TracebackType
from typing import Self

from hw.types import JointCommand, RobotState


class Lifecycle(enum.Enum):
    """States of a hardware robot (ros2_control's lifecycle): see `hw.hardware_robot` and `hw.dds.robot`."""

    UNCONFIGURED = "unconfigured"
    INACTIVE = "inactive"
    ACTIVATING = "activating"
    ACTIVE = "active"
    ERROR = "error"
    CLOSED = "closed"


class RobotInterface(abc.ABC):
    """One robot: read its state, write a joint command, always end damped.

    Usable with `with`; `close()` is safe to call twice and a robot that is never closed
    warns when collected, like python-can's `BusABC`.
    """

    def __init__(self) -> None:
        self._closed = False

    @property
    @abc.abstractmethod
    def joint_names(self) -> tuple[str, ...]:
        """Joint names in the order of every joint array this robot reads and writes."""

    @abc.abstractmethod
    def read(self) -> RobotState:
        """Latest state of the robot."""

    @abc.abstractmethod
    def write(self, command: JointCommand) -> None:
        """Command every joint; the backend applies it until the next write."""

    @abc.abstractmethod
    def damp(self) -> None:
        """Put every joint into damping (kp 0): the safe state."""

    def _shutdown(self) -> None:  # noqa: B027 - optional hook, most backends hold nothing to release
        """Release backend resources; called once by `close()` after damping."""

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self.damp()
        finally:
            self._shutdown()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    def __del__(self) -> None:
        if not getattr(self, "_closed", True):
            warnings.warn(f"{type(self).__name__} was not closed; call close() or use 'with'", ResourceWarning, stacklevel=2)
