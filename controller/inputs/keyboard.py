"""Terminal keyboard driving: W/S forward/back, A/D left/right, Q/E turn, space zero.

Enter = start, X = stop (zero and stand), Esc or K = emergency stop (damping).
With an instruction inbox (`g1ctl run` with the planner), / or T opens a text line on the
status line (`text_line.edit_line`): keys type into it and Enter sends it to the inbox. While
typing, letters are text (K types a k: "walk" needs it) and Esc is the e-stop; Ctrl-C still
ends the run (the terminal's interrupt stays on).
Key handling is the pure `apply_key`; `KeyboardSource` reads raw keys from a TTY. A
closed terminal makes the keyboard not alive (the run loop then commands zero and damps);
a read that fails otherwise is logged and counted (`read_errors`), and after a few in a
row the reader gives up.
"""

from __future__ import annotations

import codecs
import errno
import logging
import os
import select
import sys
import termios
import threading
import time
import tty
from dataclasses import dataclass, field, replace

from controller.commands.velocity import CommandLimits, VelocityCommand
from controller.inputs.base import Buttons, CommandSample, CommandSource
from controller.inputs.instructions import InstructionInbox
from controller.inputs.text_line import OPEN_KEYS, edit_line
from hw.errors import InputDeviceError

log = logging.getLogger(__name__)

READ_POLL_S = 0.05  # the reader waits for a key this long at a time, then looks whether it should stop
MAX_CONSECUTIVE_READ_ERRORS = 3
JOIN_TIMEOUT_S = 1.0

HELP = "keys: W/S fwd/back  A/D left/right  Q/E turn  space zero  Enter start  X stop  Esc/K e-stop  1 wave 2 raise 3 point (again: end)"
TEXT_HELP = "  / or T type an instruction (Enter sends it; while typing, Esc is the e-stop and letters are text)"
GESTURE_KEYS = {"1": "wave", "2": "raise_both", "3": "point"}  # a terminal sends no key release: a second press ends it
ESTOP_KEYS = ("\x1b", "k")


@dataclass(frozen=True)
class KeyboardState:
    velocity: VelocityCommand = field(default_factory=VelocityCommand)
    buttons: Buttons = field(default_factory=Buttons)
    gesture: str = ""
    line: str | None = None  # the instruction being typed (None: the text line is closed)
    sent: str | None = None  # the instruction Enter just sent (the reader hands it on and clears it)


def apply_key(state: KeyboardState, key: str, limits: CommandLimits, step: float = 0.1, text: bool = False) -> KeyboardState:
    """The state after one key press; unknown keys change nothing. Buttons latch until the next key.

    `text`: instructions can be typed (/ or T opens the text line); while it is open, Esc still e-stops and every other
    key edits the line."""
    if state.line is not None:
        if key == ESTOP_KEYS[0]:
            return KeyboardState(buttons=Buttons(estop=True))
        line, sent = edit_line(state.line, key)
        return replace(state, line=line, sent=sent)
    v = state.velocity
    k = key.lower()
    if text and k in OPEN_KEYS:
        return replace(state, line="")
    if k in GESTURE_KEYS:
        return replace(state, gesture="" if state.gesture == GESTURE_KEYS[k] else GESTURE_KEYS[k])
    deltas = {"w": (step, 0, 0), "s": (-step, 0, 0), "a": (0, step, 0), "d": (0, -step, 0), "q": (0, 0, step), "e": (0, 0, -step)}
    if k in deltas:
        dx, dy, dz = deltas[k]
        new_v = limits.clamp(VelocityCommand(round(v.vx + dx, 6), round(v.vy + dy, 6), round(v.yaw_rate + dz, 6)))
        return KeyboardState(velocity=new_v, gesture=state.gesture)
    if k == " ":
        return KeyboardState()
    if k in ("\r", "\n"):
        return replace(state, buttons=Buttons(start=True))
    if k == "x":
        return KeyboardState(buttons=Buttons(stop=True))
    if k in ESTOP_KEYS:
        return KeyboardState(buttons=Buttons(estop=True))
    return state


class KeyboardSource(CommandSource):
    """Reads keys from the controlling terminal (or `stream`, a TTY) in a background thread,
    joined on `close()`, which also restores the terminal's mode. With `instructions`, the text line
    is open to typing: what it shows goes to `instructions.typing`, what Enter sends to `instructions`."""

    _needs_close = True

    def __init__(
        self, limits: CommandLimits, step: float = 0.1, stream: object | None = None, instructions: InstructionInbox | None = None
    ) -> None:
        self._fd = _tty_fd(stream or sys.stdin)
        self._limits = limits
        self._step = step
        self._instructions = instructions
        self._decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")  # typed text may be more than one byte a character
        self._state = KeyboardState()
        self._lock = threading.Lock()
        self.read_errors = 0  # failed reads other than a closed terminal, each logged
        self._saved = termios.tcgetattr(self._fd)
        tty.setcbreak(self._fd)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read_keys, name="keyboard", daemon=True)
        self._thread.start()

    def _read_keys(self) -> None:
        failures = 0
        while not self._stop.is_set() and failures < MAX_CONSECUTIVE_READ_ERRORS:
            try:
                ready, _, _ = select.select([self._fd], [], [], READ_POLL_S)
                if not ready:
                    continue
                data = os.read(self._fd, 1)
                arrived = time.perf_counter()
                if not data:
                    log.warning("the terminal closed: no more keys, commanding zero")
                    return
                key = self._decoder.decode(data)
                if key:
                    self._press(key, arrived)
            except OSError as exc:
                if exc.errno == errno.EIO:  # the terminal hung up
                    log.warning("the terminal closed (%s): no more keys, commanding zero", exc)
                    return
                failures = self._read_failed(exc, failures)
            except Exception as exc:  # never silent
                failures = self._read_failed(exc, failures)
            else:
                failures = 0
        if failures:
            log.error("keyboard reader gives up after %d failed reads in a row: commanding zero", failures)

    def _press(self, key: str, arrived: float) -> None:
        inbox = self._instructions
        with self._lock:
            state = apply_key(self._state, key, self._limits, self._step, text=inbox is not None)
            sent, self._state = state.sent, replace(state, sent=None)
        if inbox is not None:
            inbox.typing = state.line
            if sent is not None:
                inbox.submit(sent, "keyboard", arrived=arrived)

    def _read_failed(self, exc: BaseException, failures: int) -> int:
        self.read_errors += 1
        log.error("keyboard read failed (%d in a row): %s", failures + 1, exc, exc_info=exc)
        return failures + 1

    def poll(self, now: float) -> CommandSample:
        with self._lock:
            state = self._state
            self._state = replace(state, buttons=Buttons())
        return CommandSample(velocity=state.velocity, buttons=state.buttons, alive=self._thread.is_alive(), gesture=state.gesture)

    def close(self) -> None:
        """Stop the reader, wait for it (it looks at its stop flag every `READ_POLL_S`), restore the terminal."""
        if self._closed:
            return
        self._stop.set()
        self._thread.join(timeout=JOIN_TIMEOUT_S)
        if self._thread.is_alive():
            log.warning("the keyboard reader did not stop within %.1f s of close()", JOIN_TIMEOUT_S)
        try:
            termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)
        except termios.error as exc:  # a terminal that hung up cannot be restored, nor needs to be
            log.warning("could not restore the terminal's mode: %s", exc)
        super().close()


def _tty_fd(stream: object) -> int:
    try:
        fd = stream.fileno()  # type: ignore[attr-defined]
    except (AttributeError, OSError, ValueError):
        fd = -1
    if fd < 0 or not os.isatty(fd):
        raise InputDeviceError("the keyboard input needs an interactive terminal; use --input scripted or run it in a terminal")
    return int(fd)
