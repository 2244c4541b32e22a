"""`g1ctl run`: drive the simulated G1, or a real one, through the planner, the way a person would.

g1ctl run [--input auto|keyboard|gamepad|scripted|unitree-remote] [--scenario walk_turn_stop] [--video runs/run.mp4]
          [--no-planner] [--tracker NAME] [--policy NAME] [--hardware sim-can|sim-dds|g1-dds|PATH] [--duration S] [--headless]
          [--rt-priority 50] [--cpu N] [--record runs/run.mcap] [--instructions PATH|-]

With a real robot's config (`simulated: false`) the run drives that robot (the same driver,
`controller/runtime/driver.py`, no simulator): a G1 over DDS (a copy of g1-dds.yaml, the registry's
`real-dds`; its own remote is the default input), or a robot on CAN and serial buses (your bus
config, `real-buses`: bus cycles at the config's `cycle_hz` on the wall clock).

With a display: MuJoCo's viewer, the planned motion drawn as a ghost beside the robot, held
to the wall clock. Without one: headless. `--input auto` takes a gamepad when one is plugged
in, else the keyboard when this is a terminal, else the scenario's scripted timeline. In a
terminal one status line shows the mode, the command, the measured velocity and the plan
latency. `--video` records either way (with the ghost).

Instructions while it runs (`controller/text/live.py`): with the planner, the keyboard's / key
types one on the status line; `--instructions PATH` also takes them on a local Unix socket
(`g1ctl tell "wave" --to PATH`), `--instructions -` from standard input when it is not a terminal
(the run then ends once the input has ended and its instructions are over). Each is planned and
switched to at once from where the robot is; "stop" ends it and the robot stands; a refused one
leaves the robot as it was and says why. With `--instructions` and scripted input the scenario
is `stand` unless `--scenario` names one, and the run is held to the wall clock.
"""

from __future__ import annotations

import argparse
import os
import sys
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING

from controller.inputs.registry import INPUTS
from hw.dds.config import DdsHardwareConfig
from hw.errors import ConfigError

if TYPE_CHECKING:
    from controller.runtime.run_plan import RunPlan


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    run = sub.add_parser("run", help="drive the simulated G1 through the planner: viewer or headless, keyboard, gamepad or a scenario")
    run.add_argument(
        "--input", default="auto", choices=("auto", *INPUTS), help="auto: the robot's remote on a G1; gamepad, else keyboard, else scripted"
    )
    run.add_argument(
        "--scenario",
        default=None,
        help="with scripted input: shipped scenario name or YAML path (default: walk_turn_stop; stand with --instructions)",
    )
    run.add_argument("--video", type=Path, default=None, help="also record an .mp4 or .gif (with the planned ghost)")
    run.add_argument("--no-planner", action="store_true", help="track the command directly, without the planner")
    run.add_argument("--tracker", default=None, help="tracker by name (default: decoupled with the planner, else velocity)")
    run.add_argument("--policy", default="fastsac", help="locomotion policy preset or YAML")
    run.add_argument(
        "--hardware",
        default=None,
        help="simulated hardware (sim-can, sim-mixed, sim-dds), a real G1 (g1-dds or your copy) or your robot's bus config",
    )
    run.add_argument("--duration", type=float, default=None, help="seconds (default: the scenario's; interactive: until Ctrl-C)")
    run.add_argument("--headless", action="store_true", help="no viewer even where a display exists")
    run.add_argument("--report", type=Path, default=None, help="write the JSON report here (and a .png plot beside it)")
    run.add_argument("--seed", type=int, default=0)
    run.add_argument(
        "--estimator",
        action="store_true",
        help="estimate the base position from the IMU and the legs on the simulator too (hardware always does)",
    )
    run.add_argument("--estimator-config", default=None, help="the state estimator's YAML (default: configs/estimator.yaml)")
    run.add_argument("--rt-priority", type=int, default=0, help="on a real robot: SCHED_FIFO priority of the run, e.g. 50 (0: normal)")
    run.add_argument("--cpu", type=int, default=None, help="on a real robot: pin the run to this CPU")
    run.add_argument("--record", type=Path, default=None, help="record every tick into this MCAP file (g1ctl log reads it)")
    run.add_argument(
        "--instructions",
        default=None,
        metavar="PATH|-",
        help="take typed instructions while running: on a local Unix socket at PATH (g1ctl tell sends them), or '-': standard input",
    )


def run(args: argparse.Namespace) -> int:
    from controller.cli.sim import run_and_summarize  # noqa: PLC0415
    from controller.runtime.backend_registry import choose_backend  # noqa: PLC0415
    from controller.runtime.run_config import RunConfig  # noqa: PLC0415
    from controller.runtime.run_plan import resolve_run  # noqa: PLC0415

    choice = choose_backend(args.hardware)
    channel = args.instructions
    _check_instructions(channel, args.no_planner, args.input)
    on_robot = not choice.entry.simulated  # a real robot: no viewer
    viewer = not on_robot and not args.headless and bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if not on_robot and (args.video is not None or not viewer):
        from sim import use_headless_gl  # noqa: PLC0415

        use_headless_gl()
    g1_remote = on_robot and isinstance(choice.hardware, DdsHardwareConfig)  # a real G1 has its remote; a robot on buses has none
    source = "unitree-remote" if g1_remote and args.input == "auto" else _choose_input(args.input)
    scenario = args.scenario or ("stand" if channel is not None else "walk_turn_stop")
    realtime = viewer or source != "scripted" or channel is not None  # a person drives, or sends instructions
    cfg = RunConfig(
        scenario=scenario, policy=args.policy, tracker=args.tracker, planner=not args.no_planner, duration=args.duration,
        seed=args.seed, input=source, video=args.video, report=args.report, realtime=realtime, viewer=viewer,
        assets_dir=args.assets_dir, hardware=args.hardware, status=sys.stderr.isatty(), rt_priority=args.rt_priority, cpu=args.cpu,
        estimator=args.estimator, estimator_config=args.estimator_config, record=args.record,
    )  # fmt: skip
    plan = resolve_run(cfg, choice)
    if source != "scripted":
        print(f"g1ctl run: {source} input, {'viewer' if viewer else 'headless'}; Ctrl-C ends the run", file=sys.stderr)
    if channel is None and (args.no_planner or source != "keyboard"):
        return run_and_summarize(plan)
    return _run_taking_instructions(plan, channel)


def _check_instructions(channel: str | None, no_planner: bool, input_name: str) -> None:
    """One line for instructions this run cannot take."""
    if channel is None:
        return
    if no_planner:
        raise ConfigError("--instructions: instructions are planned whole-body motion; drop --no-planner")
    if channel == "-" and input_name == "keyboard":
        raise ConfigError("--instructions - reads standard input, which the keyboard reads too: use --instructions PATH, or type with /")
    if channel == "-" and sys.stdin.isatty():
        raise ConfigError("--instructions -: standard input is a terminal; pipe instructions in, or type them with the keyboard's / key")


def _run_taking_instructions(plan: RunPlan, channel: str | None) -> int:
    """The run with its live text reference: instructions from the keyboard's text line, and from `channel` (a socket
    path, or - for standard input) when given. The sentence encoder is loaded before the run starts, in the resolver's
    process."""
    from controller.cli.sim import run_and_summarize  # noqa: PLC0415
    from controller.inputs.instructions import InstructionInbox  # noqa: PLC0415
    from controller.text.live import LiveInstructions  # noqa: PLC0415

    inbox = InstructionInbox()
    with ExitStack() as stack:
        if channel == "-":
            from controller.inputs.instruction_stream import StreamInstructions  # noqa: PLC0415

            stack.enter_context(StreamInstructions(sys.stdin.fileno(), inbox, sys.stderr))
        elif channel is not None:
            from controller.inputs.instruction_socket import InstructionSocket  # noqa: PLC0415

            path = Path(channel)
            stack.enter_context(InstructionSocket(path, inbox))
            print(f'g1ctl run: instructions on {path} (g1ctl tell "wave" --to {path}); "stop" stands the robot', file=sys.stderr)
        live = stack.enter_context(LiveInstructions(inbox))  # the text planner loaded in the resolver's process, before the run
        return run_and_summarize(plan, live.hooks)


def _choose_input(choice: str) -> str:
    if choice != "auto":
        return choice
    if _gamepad_present():
        return "gamepad"
    return "keyboard" if sys.stdin.isatty() else "scripted"


def _gamepad_present() -> bool:
    try:
        import evdev  # noqa: PLC0415 - Linux only
    except ImportError:
        return False
    from controller.inputs.gamepad import find_gamepad  # noqa: PLC0415
    from hw.errors import InputDeviceError  # noqa: PLC0415

    try:
        find_gamepad(evdev).close()
    except InputDeviceError:
        return False
    return True
