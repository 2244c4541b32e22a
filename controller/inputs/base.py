"""One interface for every command input: a velocity command plus buttons."""

from __future__ import annotations

import abc
import warnings
from dataclasses import dataclass
from types import TracebackType
from typing import Self

from controller.commands.velocity import ZERO, VelocityCommand


@dataclass(frozen=True)
class Buttons:
    """Edge-free button state: held buttons read True while held."""

    start: bool = False
    stop: bool = False
    estop: bool = False


@dataclass(frozen=True)
class CommandSample:
    """What an input says at one instant. `alive` is False when the device went stale or away."""

    velocity: VelocityCommand = ZERO
    buttons: Buttons = Buttons()
    alive: bool = True
    gesture: str = ""  # an upper-body gesture asked for (a name of commands.gestures.GESTURE_LABELS); "" for none


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
