"""Command inputs by name: `--input NAME` picks one; an unknown name lists the valid ones."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from controller.commands.velocity import CommandLimits
from controller.inputs.base import CommandSource
from hw.dds.session import DdsConfig
from hw.errors import ConfigError

if TYPE_CHECKING:
    from controller.inputs.instructions import InstructionInbox
    from controller.inputs.scripted import Scenario

INPUTS = ("scripted", "keyboard", "gamepad", "unitree-remote")

REMOTE_NEEDS_DDS = "--input unitree-remote reads the G1's own remote from rt/lowstate: add --hardware g1-dds (or sim-dds)"


def check_input(name: str, remote: DdsConfig | None = None) -> None:
    """An unknown name, or the G1's remote with no robot over DDS (`remote`: its domain and interface) to read it on."""
    if name not in INPUTS:
        raise ConfigError(f"unknown input '{name}' (valid: {', '.join(INPUTS)})")
    if name == "unitree-remote" and remote is None:
        raise ConfigError(REMOTE_NEEDS_DDS)


def open_input(
    name: str, limits: CommandLimits, scenario: Scenario | None, duration: float, seed: int, remote: DdsConfig | None = None,
    instructions: InstructionInbox | None = None,
) -> CommandSource:  # fmt: skip
    """The command source of a run: a scenario's timeline (`scenario`, `duration`, `seed`), the keyboard, a gamepad,
    or the G1's own remote (read where the robot's `LowState_`s come: `remote`, its DDS domain and interface).
    `instructions`: the run takes typed instructions; the keyboard's text line sends them there."""
    check_input(name, remote)
    if name == "scripted":
        from controller.inputs.scripted import ScriptedSource, timeline  # noqa: PLC0415

        if scenario is None:
            raise ConfigError("--input scripted plays a scenario: give --scenario NAME")
        return ScriptedSource(timeline(scenario, duration, limits, seed), limits)
    if name == "keyboard":
        from controller.inputs.keyboard import HELP, TEXT_HELP, KeyboardSource  # noqa: PLC0415 - termios: a terminal only

        print(HELP + (TEXT_HELP if instructions is not None else ""), file=sys.stderr)
        return KeyboardSource(limits, instructions=instructions)
    if name == "unitree-remote":
        from controller.inputs.unitree_remote import UnitreeRemoteSource  # noqa: PLC0415 - cyclonedds: the g1 extra

        assert remote is not None  # checked above
        return UnitreeRemoteSource(remote, limits)
    from controller.inputs.gamepad import GamepadConfig, GamepadSource  # noqa: PLC0415 - evdev: Linux only

    return GamepadSource(GamepadConfig(), limits)
