"""Linux gamepad through evdev: left stick vx/vy, right stick yaw rate, buttons.

Decoding (`GamepadDecoder.feed`) and mapping (`map_gamepad`) are pure and tested on
recorded event streams; `GamepadSource` only reads events from `/dev/input/event*`.
An unplugged gamepad, or one that stops reporting while a stick is deflected, is not
alive: the run loop then commands zero and damps the robot. A read that fails otherwise
is logged and counted (`read_errors`); after a few in a row the reader gives up and the
gamepad is not alive either.
"""

from __future__ import annotations

import errno
import logging
import select
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from controller.commands.velocity import CommandLimits, VelocityCommand
from controller.inputs.base import Buttons, CommandSample, CommandSource
from hw.errors import InputDeviceError

log = logging.getLogger(__name__)

EV_SYN, EV_KEY, EV_ABS = 0, 1, 3
BTN_SOUTH, BTN_EAST, BTN_NORTH, BTN_WEST, BTN_TL, BTN_SELECT, BTN_START = 304, 305, 307, 308, 310, 314, 315
ABS_X, ABS_Y, ABS_RX = 0, 1, 3

READ_POLL_S = 0.05  # the reader waits for events this long at a time, then looks whether it should stop
MAX_CONSECUTIVE_READ_ERRORS = 3  # failed reads in a row before the reader gives up (the pad is then not alive)
JOIN_TIMEOUT_S = 1.0


@dataclass(frozen=True)
class AxisRange:
    minimum: int = -32768
    maximum: int = 32767

    def normalize(self, raw: int) -> float:
        """Map the raw value to [-1, 1] with the centre at 0."""
        centre = (self.maximum + self.minimum) / 2.0
        half = (self.maximum - self.minimum) / 2.0
        return max(-1.0, min(1.0, (raw - centre) / half)) if half > 0 else 0.0


@dataclass(frozen=True)
class GamepadConfig:
    """Which evdev codes drive what. Defaults fit Xbox-layout pads (xpad, xone, 8BitDo in X mode)."""

    axis_vx: int = ABS_Y
    axis_vy: int = ABS_X
    axis_yaw: int = ABS_RX
    invert_vx: bool = True  # stick up reads negative
    invert_vy: bool = True  # stick left reads negative; +vy is left
    invert_yaw: bool = True  # stick left reads negative; +yaw is counter-clockwise
    button_start: int = BTN_START
    button_stop: int = BTN_SOUTH
    button_estop: int = BTN_EAST
    # Held to make an upper-body gesture with the planner (first held one wins): X wave, Y raise both arms, LB point.
    gesture_buttons: tuple[tuple[int, str], ...] = ((BTN_WEST, "wave"), (BTN_NORTH, "raise_both"), (BTN_TL, "point"))
    deadzone: float = 0.1
    stale_timeout: float = 0.5  # s without events while a stick is deflected


@dataclass(frozen=True)
class GamepadState:
    """Normalized sticks in [-1, 1] by axis code, held buttons, time of the last report."""

    axes: dict[int, float] = field(default_factory=dict)
    buttons: frozenset[int] = frozenset()
    last_event_time: float = 0.0


class GamepadDecoder:
    """Folds evdev events into a `GamepadState`; a state is published on each SYN_REPORT."""

    def __init__(self, ranges: dict[int, AxisRange] | None = None) -> None:
        self.ranges = ranges or {}
        self.state = GamepadState()
        self._pending_axes: dict[int, float] = {}
        self._pending_buttons = set[int]()

    def feed(self, t: float, ev_type: int, code: int, value: int) -> GamepadState:
        """Apply one event; returns the published state (updated only on SYN_REPORT)."""
        if ev_type == EV_ABS:
            self._pending_axes[code] = self.ranges.get(code, AxisRange()).normalize(value)
        elif ev_type == EV_KEY:
            if value:
                self._pending_buttons.add(code)
            else:
                self._pending_buttons.discard(code)
        elif ev_type == EV_SYN and code == 0:
            axes = {**self.state.axes, **self._pending_axes}
            self._pending_axes.clear()
            self.state = GamepadState(axes=axes, buttons=frozenset(self._pending_buttons), last_event_time=t)
        return self.state


def apply_deadzone(x: float, deadzone: float) -> float:
    """Zero inside the deadzone, rescaled so the output still spans [-1, 1] outside it."""
    if abs(x) <= deadzone:
        return 0.0
    sign = 1.0 if x > 0 else -1.0
    return sign * (abs(x) - deadzone) / (1.0 - deadzone)


def _scale(x: float, bounds: tuple[float, float]) -> float:
    return x * bounds[1] if x >= 0 else -x * bounds[0]


def map_gamepad(state: GamepadState, cfg: GamepadConfig, limits: CommandLimits, now: float, connected: bool = True) -> CommandSample:
    """Gamepad state -> command sample; a stale or unplugged pad gives zero and `alive=False`."""

    def axis(code: int, invert: bool) -> float:
        x = apply_deadzone(state.axes.get(code, 0.0), cfg.deadzone)
        return -x if invert else x

    sx, sy, syaw = axis(cfg.axis_vx, cfg.invert_vx), axis(cfg.axis_vy, cfg.invert_vy), axis(cfg.axis_yaw, cfg.invert_yaw)
    deflected = sx != 0.0 or sy != 0.0 or syaw != 0.0
    stale = deflected and now - state.last_event_time > cfg.stale_timeout
    buttons = Buttons(
        start=cfg.button_start in state.buttons, stop=cfg.button_stop in state.buttons, estop=cfg.button_estop in state.buttons
    )
    if not connected or stale:
        return CommandSample(buttons=buttons, alive=False)
    velocity = VelocityCommand(_scale(sx, limits.vx), _scale(sy, limits.vy), _scale(syaw, limits.yaw_rate))
    gesture = next((name for code, name in cfg.gesture_buttons if code in state.buttons), "")
    return CommandSample(velocity=velocity, buttons=buttons, alive=True, gesture=gesture)


def find_gamepad(evdev: Any) -> Any:
    """The first input device with sticks and buttons; an `InputDeviceError` when there is none."""
    try:
        paths = evdev.list_devices()
    except OSError as exc:
        raise InputDeviceError(f"cannot list input devices ({exc}); check permissions on /dev/input") from exc
    for path in paths:
        device = evdev.InputDevice(path)
        caps = device.capabilities()
        if EV_ABS in caps and EV_KEY in caps:
            return device
        device.close()
    raise InputDeviceError(
        "no gamepad found under /dev/input; plug one in (and check you may read /dev/input/event*), or use --input keyboard"
    )


class GamepadSource(CommandSource):
    """Reads a gamepad with evdev in a background thread, joined on `close()`.

    `device`: an already opened evdev-like device (`fileno`, `read`, `capabilities`, `close`),
    e.g. a fake in tests; by default the one at `device_path`, or the first gamepad found."""

    _needs_close = True

    def __init__(self, cfg: GamepadConfig, limits: CommandLimits, device_path: str | None = None, device: Any = None) -> None:
        if device is None:
            try:
                import evdev  # noqa: PLC0415 - optional at import time: only this source needs it
            except ImportError as exc:
                raise InputDeviceError("the gamepad input needs the 'evdev' package (Linux); install it with 'pip install evdev'") from exc
            device = evdev.InputDevice(device_path) if device_path else find_gamepad(evdev)
        self._device = device
        abs_caps: Any = self._device.capabilities(absinfo=True).get(EV_ABS, [])
        ranges = {code: AxisRange(info.min, info.max) for code, info in abs_caps}
        self._decoder = GamepadDecoder(ranges)
        self._cfg = cfg
        self._limits = limits
        self._lock = threading.Lock()
        self._connected = True
        self._stop = threading.Event()
        self.read_errors = 0  # failed reads other than an unplug, each logged
        self._thread = threading.Thread(target=self._read_events, name="gamepad", daemon=True)
        self._thread.start()

    def _read_events(self) -> None:
        failures = 0
        try:
            while not self._stop.is_set() and failures < MAX_CONSECUTIVE_READ_ERRORS:
                try:
                    ready, _, _ = select.select([self._device], [], [], READ_POLL_S)
                    if ready:
                        for event in self._device.read():
                            with self._lock:
                                self._decoder.feed(time.monotonic(), event.type, event.code, event.value)
                except BlockingIOError:  # woken without a whole event: wait again
                    continue
                except OSError as exc:
                    if exc.errno == errno.ENODEV:
                        log.warning("gamepad unplugged (%s): commanding zero", exc)
                        return
                    failures = self._read_failed(exc, failures)
                except Exception as exc:  # a bad event or a driver bug: never silent
                    failures = self._read_failed(exc, failures)
                else:
                    failures = 0
            if failures:
                log.error("gamepad reader gives up after %d failed reads in a row: commanding zero", failures)
        finally:
            self._connected = False

    def _read_failed(self, exc: BaseException, failures: int) -> int:
        self.read_errors += 1
        log.error("gamepad read failed (%d in a row): %s", failures + 1, exc, exc_info=exc)
        return failures + 1

    def poll(self, now: float) -> CommandSample:
        with self._lock:
            state = self._decoder.state
        return map_gamepad(state, self._cfg, self._limits, time.monotonic(), connected=self._connected)

    def close(self) -> None:
        """Stop the reader, wait for it (it looks at its stop flag every `READ_POLL_S`), close the device."""
        if self._closed:
            return
        self._stop.set()
        self._thread.join(timeout=JOIN_TIMEOUT_S)
        self._device.close()
        if self._thread.is_alive():
            log.warning("the gamepad reader did not stop within %.1f s of close()", JOIN_TIMEOUT_S)
        super().close()
