"""`g1ctl run`: drive the simulated G1, or a real one, through the planner, the way a person would.

g1ctl run [--input auto|keyboard|gamepad|scripted|unitree-remote] [--scenario walk_turn_stop] [--video runs/run.mp4]
          [--no-planner] [--tracker NAME] [--policy NAME] [--hardware sim-can|sim-dds|g1-dds|PATH] [--duration S] [--headless]
          [--rt-priority 50] [--cpu N] [--record runs/run.mcap]

With a real robot's config (`simulated: false`) the run drives that robot (the same driver,
`controller/runtime/driver.py`, no simulator): a G1 over DDS (a copy of g1-dds.yaml, the registry's
`real-dds`; its own remote is the default input), or a robot on CAN and serial buses (your bus
config, `real-buses`: bus cycles at the config's `cycle_hz` on the wall clock).

With a display: MuJoCo's viewer, the planned motion drawn as a ghost beside the robot, held
to the wall clock. Without one: headless. `--input auto` takes a gamepad when one is plugged
in, else the keyboard when this is a terminal, else the scenario's scripted timeline. In a
terminal one status line shows the mode, the command, the measured velocity and the plan
latency. `--video` records either way (with the ghost).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from controller.inputs.registry import INPUTS
from hw.dds.config import DdsHardwareConfig


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    run = sub.add_parser("run", help="drive the simulated G1 through the planner: viewer or headless, keyboard, gamepad or a scenario")
    run.add_argument(
        "--input", default="auto", choices=("auto", *INPUTS), help="auto: the robot's remote on a G1; gamepad, else keyboard, else scripted"
    )
    run.add_argument("--scenario", default="walk_turn_stop", help="with scripted input: shipped scenario name or YAML path")
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


def run(args: argparse.Namespace) -> int:
    from controller.cli.sim import run_and_summarize  # noqa: PLC0415
    from controller.runtime.backend_registry import choose_backend  # noqa: PLC0415
    from controller.runtime.run_config import RunConfig  # noqa: PLC0415
    from controller.runtime.run_plan import resolve_run  # noqa: PLC0415

    choice = choose_backend(args.hardware)
    on_robot = not choice.entry.simulated  # a real robot: no viewer
    viewer = not on_robot and not args.headless and bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if not on_robot and (args.video is not None or not viewer):
        from sim import use_headless_gl  # noqa: PLC0415

        use_headless_gl()
    g1_remote = on_robot and isinstance(choice.hardware, DdsHardwareConfig)  # a real G1 has its remote; a robot on buses has none
    source = "unitree-remote" if g1_remote and args.input == "auto" else _choose_input(args.input)
    cfg = RunConfig(
        scenario=args.scenario, policy=args.policy, tracker=args.tracker, planner=not args.no_planner, duration=args.duration,
        seed=args.seed, input=source, video=args.video, report=args.report, realtime=viewer or source != "scripted", viewer=viewer,
        assets_dir=args.assets_dir, hardware=args.hardware, status=sys.stderr.isatty(), rt_priority=args.rt_priority, cpu=args.cpu,
        estimator=args.estimator, estimator_config=args.estimator_config, record=args.record,
    )  # fmt: skip
    plan = resolve_run(cfg, choice)
    if source != "scripted":
        print(f"g1ctl run: {source} input, {'viewer' if viewer else 'headless'}; Ctrl-C ends the run", file=sys.stderr)
    return run_and_summarize(plan)


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
