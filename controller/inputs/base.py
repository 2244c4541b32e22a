"""One interface for every command input: a velocity command plus buttons."""

from __future__ import annotations

import abc
import warnings
from dataclasses import dataclass
from types import TracebackType
from typing import Self


@dataclass(frozen=True)
class VelocityCommand:
    """Planar base velocity in the robot's heading frame: vx forward, vy left (m/s), yaw rate (rad/s)."""

    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0

    def is_zero(self, tol: float = 1e-3) -> bool:
        return abs(self.vx) < tol and abs(self.vy) < tol and abs(self.yaw_rate) < tol


@dataclass(frozen=True)
class Buttons:
    """Edge-free button state: held buttons read True while held."""

    start: bool = False
    stop: bool = False
    estop: bool = False


@dataclass(frozen=True)
class CommandSample:
    """What an input says at one instant. `alive` is False when the device went stale or away."""

    velocity: VelocityCommand = VelocityCommand()
    buttons: Buttons = Buttons()
    alive: bool = True
    gesture: str = ""  # an upper-body gesture asked for (a name of motion_data.dataset.GESTURES); "" for none


ZERO = VelocityCommand()


@dataclass(frozen=True)
class CommandLimits:
    """Largest magnitudes a command may reach (the policy's trained ranges)."""

    vx: tuple[float, float] = (-1.0, 1.0)
    vy: tuple[float, float] = (-1.0, 1.0)
    yaw_rate: tuple[float, float] = (-1.0, 1.0)

    def clamp(self, cmd: VelocityCommand) -> VelocityCommand:
        return VelocityCommand(
            vx=min(max(cmd.vx, self.vx[0]), self.vx[1]),
            vy=min(max(cmd.vy, self.vy[0]), self.vy[1]),
            yaw_rate=min(max(cmd.yaw_rate, self.yaw_rate[0]), self.yaw_rate[1]),
        )


class CommandSource(abc.ABC):
    """A source of commands, polled by the run loop at its own rate. Usable with `with`."""

    _closed = False

    @abc.abstractmethod
    def poll(self, now: float) -> CommandSample:
        """The command in force at time `now` (seconds on the run loop's clock)."""

    def close(self) -> None:
        self._closed = True

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    def __del__(self) -> None:
        if getattr(self, "_needs_close", False) and not self._closed:
            warnings.warn(f"{type(self).__name__} was not closed", ResourceWarning, stacklevel=2)
