"""`g1ctl plan PROMPT`: a typed instruction resolved into clauses, and run on the G1 with --sim or --hardware NAME.

g1ctl plan "walk forward two meters, then turn left 90 degrees, then wave with your right hand"
           [--sim | --hardware sim-can|sim-mixed|sim-dds|g1-dds|PATH] [--video runs/plan.mp4] [--report runs/plan.json]
           [--seed N] [--policy fastsac] [--naive] [--text] [--progress] [--record runs/plan.mcap]

Prints the decomposition (clauses, resolved quantities, gestures); with --sim runs it on the
simulated G1 directly, with --hardware through that hardware (simulated buses, the simulated G1
over DDS, or a real G1 over DDS), the planner in the loop, and prints what each clause did,
measured: by the simulator's truth where one stands behind the robot, else by the controller's
own estimate (`measured_by` in the report). A prompt the stack cannot plan is refused with one
line naming the part and what it can do (exit status 2); a plan that walks or turns, on a robot
whose state has no base position, is refused at its start with one line (exit status 1), and a
run that a fault ended damped says so in one line (exit status 1).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from hw.errors import ConfigError

if TYPE_CHECKING:
    from controller.runtime.backend_registry import BackendChoice


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    plan = sub.add_parser("plan", help="plan a typed instruction into clauses and run it on the G1 (--sim, or --hardware NAME)")
    plan.add_argument("prompt", help='what the robot should do, e.g. "walk forward two meters, then wave"')
    plan.add_argument("--sim", action="store_true", help="run the plan on the simulated G1 directly")
    plan.add_argument(
        "--hardware", default=None, help="run the plan through this hardware: simulated (sim-can, sim-mixed, sim-dds) or a real G1 (g1-dds)"
    )
    plan.add_argument(
        "--video", type=Path, default=None, help="on the simulator: an .mp4 or .gif of the run, the current clause as a caption"
    )
    plan.add_argument("--report", type=Path, default=None, help="write the JSON report here")
    plan.add_argument("--record", type=Path, default=None, help="record every tick of the run into this MCAP file (g1ctl log reads it)")
    plan.add_argument("--seed", type=int, default=0)
    plan.add_argument("--policy", default="fastsac", help="locomotion policy preset of the tracker")
    plan.add_argument("--naive", action="store_true", help="join clauses without blending (the baseline of the transition score)")
    plan.add_argument("--progress", action="store_true", help="show a progress bar")
    plan.add_argument(
        "--max-corrections", type=int, default=1, help="corrections per clause that ended off its goal or without its gesture (0: none)"
    )
    plan.add_argument(
        "--text", action="store_true", help="put each clause's text in the planner's text slot (off by default: see docs/text-planning.md)"
    )


def run(args: argparse.Namespace) -> int:
    if args.sim and args.hardware is not None:
        raise ConfigError("--sim and --hardware: choose one (--sim: the simulator directly; --hardware NAME: through that hardware)")
    runs = args.sim or args.hardware is not None
    if args.video is not None and not runs:
        raise ConfigError("--video needs a run to film: add --sim, or --hardware with simulated hardware (sim-can, sim-mixed, sim-dds)")
    if args.record is not None:
        if not runs:
            raise ConfigError("--record needs a run to record: add --sim, or --hardware NAME")
        from controller.recording.sink import check_record_path  # noqa: PLC0415

        check_record_path(args.record)  # before the sentence encoder loads
    hardware = _hardware(args) if args.hardware is not None else None
    on_robot = hardware is not None and not hardware.entry.simulated
    if args.video is not None and not on_robot:
        from sim import use_headless_gl  # noqa: PLC0415

        use_headless_gl()  # before MuJoCo is imported
    from controller.text.service import TextPlanner  # noqa: PLC0415 - loads the sentence encoder

    planner = TextPlanner.load(condition_text=args.text)
    program = planner.resolve(args.prompt)
    print(planner.describe(program))
    if not runs:
        if args.report is not None:
            from controller.reports import write_report  # noqa: PLC0415

            write_report({"prompt": program.prompt, "decomposition": planner.describe(program).splitlines()}, args.report)
            print(f"report: {args.report}")
        return 0
    report = planner.simulate(program, seed=args.seed, policy=args.policy, video=args.video, report=args.report,
                              blend=not args.naive, progress=args.progress, hardware=hardware,
                              status=on_robot and sys.stderr.isatty(), record=args.record,
                              max_corrections=args.max_corrections)  # fmt: skip
    for c in report["clauses"]:
        flags = " (timed out)" if c["timed_out"] else ""
        flags += "".join(f" (corrected: {k['reason']})" for k in c["corrections"])
        print(
            f"{c['start_s']:6.2f}-{c['end_s']:6.2f} s  {c['text']!r}: {_moved(c['displacement'])}, "
            f"turned {c['heading_change_deg']:+.0f} deg, gestures {c['gestures'] or 'none'}{flags}"
        )
    keys = ("measured_by", "total_displacement", "total_displacement_estimate", "total_heading_change_deg",
            "total_heading_change_deg_estimate", "order_accuracy", "transition_score", "corrections", "falls")  # fmt: skip
    print(json.dumps({k: report[k] for k in keys if k in report}))
    for key, path in (("video", args.video), ("report", args.report), ("recording", args.record)):
        if path is not None:
            print(f"{key}: {path}")
    from controller.cli.sim import print_fault_ending  # noqa: PLC0415

    faulted = print_fault_ending(report["run"])  # hardware: a stale robot, a motor fault; the robot damped
    return 1 if report["falls"] or faulted else 0


def _hardware(args: argparse.Namespace) -> BackendChoice:
    """`--hardware`, loaded once for the whole command; on a real G1 the options it cannot honour are refused here, before
    anything loads."""
    from controller.runtime.backend_registry import choose_backend  # noqa: PLC0415
    from controller.runtime.run_config import RunConfig  # noqa: PLC0415
    from controller.runtime.run_plan import check_options  # noqa: PLC0415

    choice = choose_backend(args.hardware)
    if not choice.entry.simulated:
        check_options(RunConfig(hardware=args.hardware, video=args.video), choice.entry)  # one line for --video, as `g1ctl run` says it
        if args.progress:
            raise ConfigError("--progress: not on a real robot (the status line shows the run and the clause running)")
    return choice


def _moved(displacement: list[float] | None) -> str:
    if displacement is None:
        return "moved ? (no base position)"
    forward, left = displacement
    return f"moved {forward:+.2f} m forward, {left:+.2f} m left"
