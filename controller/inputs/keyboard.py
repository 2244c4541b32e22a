"""Terminal keyboard driving: W/S forward/back, A/D left/right, Q/E turn, space zero.

Enter = start, X = stop (zero and stand), Esc or K = emergency stop (damping).
Key handling is the pure `apply_key`; `KeyboardSource` reads raw keys from a TTY.
"""

from __future__ import annotations

import os
import select
import sys
import termios
import threading
import tty
from dataclasses import dataclass, field, replace

from controller.inputs.base import Buttons, CommandLimits, CommandSample, CommandSource, VelocityCommand
from hw.errors import InputDeviceError

HELP = "keys: W/S fwd/back  A/D left/right  Q/E turn  space zero  Enter start  X stop  Esc/K e-stop"


@dataclass(frozen=True)
class KeyboardState:
    velocity: VelocityCommand = field(default_factory=VelocityCommand)
    buttons: Buttons = field(default_factory=Buttons)


def apply_key(state: KeyboardState, key: str, limits: CommandLimits, step: float = 0.1) -> KeyboardState:
    """The state after one key press; unknown keys change nothing. Buttons latch until the next key."""
    v = state.velocity
    k = key.lower()
    deltas = {"w": (step, 0, 0), "s": (-step, 0, 0), "a": (0, step, 0), "d": (0, -step, 0), "q": (0, 0, step), "e": (0, 0, -step)}
    if k in deltas:
        dx, dy, dz = deltas[k]
        new_v = limits.clamp(VelocityCommand(round(v.vx + dx, 6), round(v.vy + dy, 6), round(v.yaw_rate + dz, 6)))
        return KeyboardState(velocity=new_v)
    if k == " ":
        return KeyboardState()
    if k in ("\r", "\n"):
        return replace(state, buttons=Buttons(start=True))
    if k == "x":
        return KeyboardState(buttons=Buttons(stop=True))
    if k in ("\x1b", "k"):
        return KeyboardState(buttons=Buttons(estop=True))
    return state


class KeyboardSource(CommandSource):
    """Reads keys from the controlling terminal in a background thread."""

    _needs_close = True

    def __init__(self, limits: CommandLimits, step: float = 0.1, stream: object | None = None) -> None:
        self._fd = _tty_fd(stream or sys.stdin)
        self._limits = limits
        self._step = step
        self._state = KeyboardState()
        self._lock = threading.Lock()
        self._saved = termios.tcgetattr(self._fd)
        tty.setcbreak(self._fd)
        self._running = True
        self._thread = threading.Thread(target=self._read_keys, name="keyboard", daemon=True)
        self._thread.start()

    def _read_keys(self) -> None:
        while self._running:
            ready, _, _ = select.select([self._fd], [], [], 0.05)
            if not ready:
                continue
            key = os.read(self._fd, 1).decode(errors="ignore")
            with self._lock:
                self._state = apply_key(self._state, key, self._limits, self._step)

    def poll(self, now: float) -> CommandSample:
        with self._lock:
            state = self._state
            self._state = replace(state, buttons=Buttons())
        return CommandSample(velocity=state.velocity, buttons=state.buttons, alive=self._thread.is_alive())

    def close(self) -> None:
        if self._closed:
            return
        self._running = False
        self._thread.join(timeout=0.5)
        termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)
        super().close()


def _tty_fd(stream: object) -> int:
    try:
        fd = stream.fileno()  # type: ignore[attr-defined]
    except (AttributeError, OSError, ValueError):
        fd = -1
    if fd < 0 or not os.isatty(fd):
        raise InputDeviceError("the keyboard input needs an interactive terminal; use --input scripted or run it in a terminal")
    return int(fd)
