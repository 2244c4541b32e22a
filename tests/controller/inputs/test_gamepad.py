"""Gamepad decoding and mapping on a recorded-format evdev event stream; the reader thread on a fake device."""

from __future__ import annotations

import errno
import json
import logging
import os
import queue
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import pytest

from controller.commands.velocity import CommandLimits
from controller.inputs.gamepad import (
    ABS_RX,
    ABS_X,
    ABS_Y,
    EV_ABS,
    EV_SYN,
    MAX_CONSECUTIVE_READ_ERRORS,
    AxisRange,
    GamepadConfig,
    GamepadDecoder,
    GamepadSource,
    GamepadState,
    apply_deadzone,
    map_gamepad,
)
from tests.conftest import wait_for

STREAM = Path(__file__).resolve().parents[2] / "data" / "gamepad_xbox_session.jsonl"
LIMITS = CommandLimits(vx=(-0.6, 1.0), vy=(-0.5, 0.5), yaw_rate=(-1.0, 1.0))
CFG = GamepadConfig()


def replay(until: float) -> GamepadState:
    decoder = GamepadDecoder()
    for line in STREAM.read_text().splitlines():
        if line.startswith("#"):
            continue
        t, ev_type, code, value = json.loads(line)
        if t > until:
            break
        decoder.feed(t, ev_type, code, value)
    return decoder.state


def test_axis_normalization_and_deadzone() -> None:
    rng = AxisRange(-32768, 32767)
    assert rng.normalize(-32768) == -1.0
    assert rng.normalize(32767) == 1.0
    assert abs(rng.normalize(0)) < 1e-4
    assert AxisRange(0, 255).normalize(255) == 1.0
    assert apply_deadzone(0.05, 0.1) == 0.0
    assert apply_deadzone(1.0, 0.1) == 1.0
    assert apply_deadzone(-0.55, 0.1) == pytest.approx(-0.5)


def test_noise_inside_deadzone_commands_zero() -> None:
    state = replay(0.03)
    sample = map_gamepad(state, CFG, LIMITS, now=state.last_event_time)
    assert sample.alive and sample.velocity.is_zero()


def test_full_forward_stick_scales_to_forward_limit() -> None:
    state = replay(0.06)
    sample = map_gamepad(state, CFG, LIMITS, now=state.last_event_time)
    assert sample.velocity.vx == pytest.approx(1.0)
    assert sample.velocity.vy == 0.0


def test_stick_left_strafes_left_and_right_stick_turns_clockwise() -> None:
    state = replay(0.78)
    sample = map_gamepad(state, CFG, LIMITS, now=state.last_event_time)
    assert sample.velocity.vy == pytest.approx(0.5 * apply_deadzone(16384 / 32767.5, 0.1), rel=1e-3)
    assert sample.velocity.yaw_rate == pytest.approx(-1.0)


def test_released_sticks_and_buttons() -> None:
    state = replay(1.2)
    sample = map_gamepad(state, CFG, LIMITS, now=10.0)  # long idle with centred sticks is not stale
    assert sample.alive and sample.velocity.is_zero()
    assert replay(1.2).buttons == frozenset({304})
    pressed = map_gamepad(replay(1.2), CFG, LIMITS, now=1.2)
    assert pressed.buttons.stop and not pressed.buttons.estop
    assert map_gamepad(replay(1.45), CFG, LIMITS, now=1.45).buttons.start
    assert map_gamepad(replay(9.0), CFG, LIMITS, now=9.0).buttons.estop


def test_deflected_stick_without_reports_is_stale() -> None:
    state = replay(0.06)
    sample = map_gamepad(state, CFG, LIMITS, now=state.last_event_time + CFG.stale_timeout + 0.1)
    assert not sample.alive and sample.velocity.is_zero()


def test_unplugged_gamepad_gives_zero_and_not_alive() -> None:
    state = replay(0.06)
    sample = map_gamepad(state, CFG, LIMITS, now=state.last_event_time, connected=False)
    assert not sample.alive and sample.velocity.is_zero()


def test_no_gamepad_present_is_one_clear_error() -> None:
    from controller.inputs.gamepad import find_gamepad
    from hw.errors import InputDeviceError

    class NoDevices:
        @staticmethod
        def list_devices() -> list[str]:
            return []

    with pytest.raises(InputDeviceError, match="no gamepad found"):
        find_gamepad(NoDevices)


class FakeEvdevDevice:
    """Stands for an `evdev.InputDevice`: a pipe makes it selectable; `push` queues what the
    next `read()` returns (a batch of events) or raises (an exception)."""

    def __init__(self) -> None:
        self._r, self._w = os.pipe()
        self._pending: queue.Queue[list[InputEvent] | BaseException] = queue.Queue()
        self.closed = False

    def capabilities(self, absinfo: bool = True) -> dict[int, list[tuple[int, AbsInfo]]]:
        return {EV_ABS: [(code, AbsInfo(-32768, 32767)) for code in (ABS_X, ABS_Y, ABS_RX)]}

    def fileno(self) -> int:
        return self._r

    def push(self, item: list[InputEvent] | BaseException) -> None:
        self._pending.put(item)
        os.write(self._w, b"x")

    def read(self) -> Iterator[InputEvent]:
        os.read(self._r, 1)
        item = self._pending.get_nowait()
        if isinstance(item, BaseException):
            raise item
        return iter(item)

    def close(self) -> None:
        assert not self.closed, "closed twice"
        self.closed = True
        os.close(self._r)
        os.close(self._w)


class AbsInfo(NamedTuple):
    min: int
    max: int


class InputEvent(NamedTuple):
    type: int
    code: int
    value: int


FULL_FORWARD = [InputEvent(EV_ABS, ABS_Y, -32768), InputEvent(EV_SYN, 0, 0)]


@pytest.fixture
def pad() -> Iterator[tuple[GamepadSource, FakeEvdevDevice]]:
    device = FakeEvdevDevice()
    source = GamepadSource(CFG, LIMITS, device=device)
    yield source, device
    source.close()


def test_source_reads_events_from_the_device(pad: tuple[GamepadSource, FakeEvdevDevice]) -> None:
    source, device = pad
    device.push(FULL_FORWARD)
    assert wait_for(lambda: source.poll(0.0).velocity.vx == pytest.approx(1.0))
    assert source.poll(0.0).alive and source.read_errors == 0


def test_close_joins_the_reader_and_closes_the_device_once(pad: tuple[GamepadSource, FakeEvdevDevice]) -> None:
    source, device = pad
    thread = source._thread
    assert thread.is_alive()
    source.close()
    assert not thread.is_alive() and device.closed
    source.close()  # safe twice: the fake device asserts it is closed once


def test_unplug_is_not_alive_and_not_a_read_error(pad: tuple[GamepadSource, FakeEvdevDevice], caplog: pytest.LogCaptureFixture) -> None:
    source, device = pad
    device.push(FULL_FORWARD)
    device.push(OSError(errno.ENODEV, "No such device"))
    assert wait_for(lambda: not source.poll(0.0).alive)
    assert source.poll(0.0).velocity.is_zero() and source.read_errors == 0
    assert "gamepad unplugged" in caplog.text


def test_read_errors_are_logged_and_counted_and_a_run_of_them_gives_up(
    pad: tuple[GamepadSource, FakeEvdevDevice], caplog: pytest.LogCaptureFixture
) -> None:
    source, device = pad
    caplog.set_level(logging.ERROR, logger="controller.inputs.gamepad")
    device.push(OSError(errno.EIO, "Input/output error"))
    assert wait_for(lambda: source.read_errors == 1)
    device.push(FULL_FORWARD)  # one failed read is survived
    assert wait_for(lambda: source.poll(0.0).velocity.vx == pytest.approx(1.0))
    assert source.poll(0.0).alive
    assert "gamepad read failed (1 in a row): [Errno 5] Input/output error" in caplog.text
    for _ in range(MAX_CONSECUTIVE_READ_ERRORS):
        device.push(ValueError("bad event"))
    assert wait_for(lambda: not source.poll(0.0).alive)
    assert source.read_errors == 1 + MAX_CONSECUTIVE_READ_ERRORS
    assert "ValueError: bad event" in caplog.text  # with its traceback
    assert f"gives up after {MAX_CONSECUTIVE_READ_ERRORS} failed reads in a row" in caplog.text


def test_held_x_waves_while_the_sticks_drive() -> None:
    state = GamepadState(axes={ABS_Y: -1.0}, buttons=frozenset({308}), last_event_time=0.0)
    sample = map_gamepad(state, CFG, LIMITS, now=0.0)
    assert sample.gesture == "wave" and sample.velocity.vx > 0
    assert map_gamepad(GamepadState(), CFG, LIMITS, now=0.0).gesture == ""
