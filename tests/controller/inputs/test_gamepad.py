"""Gamepad decoding and mapping on a recorded-format evdev event stream."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from controller.inputs.base import CommandLimits
from controller.inputs.gamepad import AxisRange, GamepadConfig, GamepadDecoder, GamepadState, apply_deadzone, map_gamepad

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
