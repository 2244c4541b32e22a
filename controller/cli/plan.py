"""`g1ctl plan PROMPT`: a typed instruction resolved into clauses, and run on the simulated G1 with --sim.

g1ctl plan "walk forward two meters, then turn left 90 degrees, then wave with your right hand"
           [--sim] [--video runs/plan.mp4] [--report runs/plan.json] [--seed N] [--policy fastsac] [--naive] [--no-text] [--progress]

Prints the decomposition (clauses, resolved quantities, gestures); with --sim runs it through
the planner in the loop and prints what each clause did, measured. A prompt the stack cannot
plan is refused with one line naming the part and what it can do (exit status 2).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from hw.errors import ConfigError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    plan = sub.add_parser("plan", help="plan a typed instruction into clauses and run it on the simulated G1 (--sim)")
    plan.add_argument("prompt", help='what the robot should do, e.g. "walk forward two meters, then wave"')
    plan.add_argument("--sim", action="store_true", help="run the plan on the simulated G1")
    plan.add_argument("--video", type=Path, default=None, help="with --sim: an .mp4 or .gif of the run, the current clause as a caption")
    plan.add_argument("--report", type=Path, default=None, help="write the JSON report here")
    plan.add_argument("--seed", type=int, default=0)
    plan.add_argument("--policy", default="fastsac", help="locomotion policy preset of the tracker")
    plan.add_argument("--naive", action="store_true", help="join clauses without blending (the baseline of the transition score)")
    plan.add_argument("--progress", action="store_true", help="show a progress bar")
    plan.add_argument(
        "--no-text", action="store_true", help="leave the planner's text slot empty (each clause's text conditions it by default)"
    )


def run(args: argparse.Namespace) -> int:
    if args.video is not None and not args.sim:
        raise ConfigError("--video needs --sim: only a simulated run has something to film")
    if args.video is not None:
        from sim import use_headless_gl  # noqa: PLC0415

        use_headless_gl()  # before MuJoCo is imported
    from controller.text.service import TextPlanner  # noqa: PLC0415 - loads the sentence encoder

    planner = TextPlanner.load(condition_text=not args.no_text)
    program = planner.resolve(args.prompt)
    print(planner.describe(program))
    if not args.sim:
        if args.report is not None:
            from controller.reports import write_report  # noqa: PLC0415

            write_report({"prompt": program.prompt, "decomposition": planner.describe(program).splitlines()}, args.report)
            print(f"report: {args.report}")
        return 0
    report = planner.simulate(program, seed=args.seed, policy=args.policy, video=args.video, report=args.report,
                              blend=not args.naive, progress=args.progress)  # fmt: skip
    for c in report["clauses"]:
        forward, left = c["displacement"]
        flags = " (timed out)" if c["timed_out"] else ""
        print(
            f"{c['start_s']:6.2f}-{c['end_s']:6.2f} s  {c['text']!r}: moved {forward:+.2f} m forward, {left:+.2f} m left, "
            f"turned {c['heading_change_deg']:+.0f} deg, gestures {c['gestures'] or 'none'}{flags}"
        )
    keys = ("total_displacement", "total_heading_change_deg", "order_accuracy", "transition_score", "falls")
    print(json.dumps({k: report[k] for k in keys}))
    for key, path in (("video", args.video), ("report", args.report)):
        if path is not None:
            print(f"{key}: {path}")
    return 1 if report["falls"] else 0
