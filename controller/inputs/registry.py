"""Command inputs by name: `--input NAME` picks one; an unknown name lists the valid ones."""

from __future__ import annotations

import sys

from controller.commands.velocity import CommandLimits
from controller.inputs.base import CommandSource
from hw.dds.session import DdsConfig
from hw.errors import ConfigError

INPUTS = ("scripted", "keyboard", "gamepad", "unitree-remote")

REMOTE_NEEDS_DDS = "--input unitree-remote reads the G1's own remote from rt/lowstate: add --hardware g1-dds (or sim-dds)"


def check_input(name: str, hardware: str | None = None) -> None:
    """An unknown name, or the G1's remote without a DDS hardware config (`hardware`) to read it on."""
    if name not in INPUTS:
        raise ConfigError(f"unknown input '{name}' (valid: {', '.join(INPUTS)})")
    if name == "unitree-remote":
        _remote_dds(hardware)


def _remote_dds(hardware: str | None) -> DdsConfig:
    """The domain and interface the G1's `LowState_`s (and so its remote) come on: the DDS hardware config's."""
    from hw.dds.config import DdsHardwareConfig  # noqa: PLC0415
    from hw.jointmap import load_robot_config  # noqa: PLC0415

    config = load_robot_config(hardware) if hardware is not None else None
    if not isinstance(config, DdsHardwareConfig):
        raise ConfigError(REMOTE_NEEDS_DDS)
    return config.dds


def open_input(name: str, limits: CommandLimits, scenario: str, duration: float, seed: int, hardware: str | None = None) -> CommandSource:
    """The command source of a run: a scenario's timeline (`scenario`, `duration`, `seed`), the keyboard, a gamepad,
    or the G1's own remote (on the DDS hardware config `hardware`)."""
    check_input(name, hardware)
    if name == "scripted":
        from controller.inputs.scripted import ScriptedSource, load_scenario, timeline  # noqa: PLC0415

        return ScriptedSource(timeline(load_scenario(scenario), duration, limits, seed), limits)
    if name == "keyboard":
        from controller.inputs.keyboard import HELP, KeyboardSource  # noqa: PLC0415 - termios: a terminal only

        print(HELP, file=sys.stderr)
        return KeyboardSource(limits)
    if name == "unitree-remote":
        from controller.inputs.unitree_remote import UnitreeRemoteSource  # noqa: PLC0415 - cyclonedds: the g1 extra

        return UnitreeRemoteSource(_remote_dds(hardware), limits)
    from controller.inputs.gamepad import GamepadConfig, GamepadSource  # noqa: PLC0415 - evdev: Linux only

    return GamepadSource(GamepadConfig(), limits)
