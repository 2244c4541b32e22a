"""Command inputs by name: `--input NAME` picks one; an unknown name lists the valid ones."""

from __future__ import annotations

import sys

from controller.inputs.base import CommandLimits, CommandSource
from hw.errors import ConfigError

INPUTS = ("scripted", "keyboard", "gamepad")


def check_input(name: str) -> None:
    if name not in INPUTS:
        raise ConfigError(f"unknown input '{name}' (valid: {', '.join(INPUTS)})")


def open_input(name: str, limits: CommandLimits, scenario: str, duration: float, seed: int) -> CommandSource:
    """The command source of a run: a scenario's timeline (`scenario`, `duration`, `seed`), the keyboard or a gamepad."""
    check_input(name)
    if name == "scripted":
        from controller.inputs.scripted import ScriptedSource, load_scenario, timeline  # noqa: PLC0415

        return ScriptedSource(timeline(load_scenario(scenario), duration, limits, seed), limits)
    if name == "keyboard":
        from controller.inputs.keyboard import HELP, KeyboardSource  # noqa: PLC0415 - termios: a terminal only

        print(HELP, file=sys.stderr)
        return KeyboardSource(limits)
    from controller.inputs.gamepad import GamepadConfig, GamepadSource  # noqa: PLC0415 - evdev: Linux only

    return GamepadSource(GamepadConfig(), limits)
