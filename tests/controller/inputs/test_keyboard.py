from __future__ import annotations

import io

import pytest

from controller.inputs.base import CommandLimits
from controller.inputs.keyboard import KeyboardSource, KeyboardState, apply_key
from hw.errors import InputDeviceError

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
