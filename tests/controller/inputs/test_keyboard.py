"""Keyboard key handling, and the reader thread on a pseudo-terminal."""

from __future__ import annotations

import io
import logging
import termios
from collections.abc import Iterator

import pytest

from controller.commands.velocity import CommandLimits
from controller.inputs import keyboard
from controller.inputs.keyboard import MAX_CONSECUTIVE_READ_ERRORS, KeyboardSource, KeyboardState, apply_key
from hw.errors import InputDeviceError
from tests.conftest import Terminal, wait_for

LIMITS = CommandLimits(vx=(-0.5, 0.5))


def press(keys: str) -> KeyboardState:
    state = KeyboardState()
    for key in keys:
        state = apply_key(state, key, LIMITS)
    return state


def test_keys_step_velocity_within_limits() -> None:
    assert press("ww").velocity.vx == pytest.approx(0.2)
    assert press("wwwwwwww").velocity.vx == 0.5  # clamped to the limit
    assert press("ad").velocity.vy == 0.0
    assert press("q").velocity.yaw_rate == pytest.approx(0.1)
    assert press("ww ").velocity.is_zero()


def test_buttons() -> None:
    assert press("wx").buttons.stop and press("wx").velocity.is_zero()
    assert press("w\x1b").buttons.estop
    assert press("w\n").buttons.start and press("w\n").velocity.vx == pytest.approx(0.1)


def test_keyboard_without_terminal_is_clear_error() -> None:
    with pytest.raises(InputDeviceError, match="interactive terminal"):
        KeyboardSource(LIMITS, stream=io.StringIO())


@pytest.fixture
def terminal() -> Iterator[Terminal]:
    term = Terminal()
    yield term
    term.close()


def test_source_reads_keys_and_close_joins_the_reader_and_restores_the_terminal(terminal: Terminal) -> None:
    before = termios.tcgetattr(terminal.slave)
    source = KeyboardSource(LIMITS, stream=terminal)
    assert termios.tcgetattr(terminal.slave) != before  # cbreak while reading
    terminal.type("ww")
    assert wait_for(lambda: source.poll(0.0).velocity.vx == pytest.approx(0.2))
    thread = source._thread
    source.close()
    assert not thread.is_alive()
    assert termios.tcgetattr(terminal.slave) == before
    source.close()  # safe twice
    assert source.read_errors == 0


def test_hung_up_terminal_is_not_alive_and_not_a_read_error(terminal: Terminal, caplog: pytest.LogCaptureFixture) -> None:
    source = KeyboardSource(LIMITS, stream=terminal)
    with source:
        terminal.hang_up()
        assert wait_for(lambda: not source.poll(0.0).alive)
        assert source.read_errors == 0
    assert "the terminal closed" in caplog.text


def test_read_errors_are_logged_and_counted_and_a_run_of_them_gives_up(
    terminal: Terminal, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    caplog.set_level(logging.ERROR, logger="controller.inputs.keyboard")
    failures = iter([ValueError("bad key"), None, *[ValueError("bad key")] * MAX_CONSECUTIVE_READ_ERRORS])
    real_apply_key = keyboard.apply_key

    def flaky_apply_key(*args: object, **kwargs: object) -> KeyboardState:
        failure = next(failures)
        if failure is not None:
            raise failure
        return real_apply_key(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(keyboard, "apply_key", flaky_apply_key)
    source = KeyboardSource(LIMITS, stream=terminal)
    with source:
        terminal.type("w")
        assert wait_for(lambda: source.read_errors == 1)
        terminal.type("w")  # one failed read is survived
        assert wait_for(lambda: source.poll(0.0).velocity.vx == pytest.approx(0.1))
        assert source.poll(0.0).alive
        terminal.type("w" * MAX_CONSECUTIVE_READ_ERRORS)
        assert wait_for(lambda: not source.poll(0.0).alive)
        assert source.read_errors == 1 + MAX_CONSECUTIVE_READ_ERRORS
    assert "keyboard read failed (1 in a row): bad key" in caplog.text
    assert "ValueError: bad key" in caplog.text  # with its traceback
    assert f"gives up after {MAX_CONSECUTIVE_READ_ERRORS} failed reads in a row" in caplog.text


def test_number_keys_toggle_gestures_and_keep_the_velocity() -> None:
    limits = CommandLimits()
    state = apply_key(KeyboardState(), "w", limits)
    state = apply_key(state, "1", limits)
    assert state.gesture == "wave" and state.velocity.vx == pytest.approx(0.1)
    state = apply_key(state, "w", limits)
    assert state.gesture == "wave" and state.velocity.vx == pytest.approx(0.2)
    assert apply_key(state, "2", limits).gesture == "raise_both"
    assert apply_key(state, "1", limits).gesture == ""
