"""`g1ctl sim`: run a command scenario on the simulated G1 and report how well it tracked.

g1ctl sim --scenario walk_turn_stop [--policy fastsac] [--tracker velocity] [--duration S] [--seed N]
          [--video runs/demo.mp4] [--picture last.png] [--report runs/report.json] [--realtime] [--viewer]
          [--input scripted|keyboard|gamepad|unitree-remote] [--hardware sim-can|sim-mixed|sim-dds|PATH] [--faults FILE] [--progress]
          [--perturb push|rough|FILE] [--record runs/run.mcap]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from controller.inputs.registry import INPUTS
from hw.errors import ConfigError

if TYPE_CHECKING:
    from controller.runtime.run_config import RunHooks
    from controller.runtime.run_plan import RunPlan


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    sim = sub.add_parser("sim", help="run a command scenario on the simulated G1")
    sim.add_argument("--scenario", default="walk_turn_stop", help="shipped scenario name or path to a scenario YAML")
    sim.add_argument("--policy", default="fastsac", help="policy preset name or path to a policy YAML")
    sim.add_argument("--tracker", default=None, help="tracker by name (default: decoupled with --planner, else velocity)")
    sim.add_argument("--planner", action="store_true", help="plan whole-body motion from the commands (replanned at 10 Hz) and track it")
    sim.add_argument("--duration", type=float, default=None, help="seconds of simulated time (default: the scenario's)")
    sim.add_argument("--seed", type=int, default=0)
    sim.add_argument(
        "--estimator",
        action="store_true",
        help="estimate the base position from the IMU and the legs on the simulator too (hardware always does)",
    )
    sim.add_argument("--estimator-config", default=None, help="the state estimator's YAML (default: configs/estimator.yaml)")
    sim.add_argument("--input", default="scripted", choices=INPUTS)
    sim.add_argument("--video", type=Path, default=None, help="write an .mp4 or .gif of the run")
    sim.add_argument("--video-fps", type=int, default=20)
    sim.add_argument("--picture", type=Path, default=None, help="write a .png of the final frame")
    sim.add_argument("--report", type=Path, default=None, help="write the JSON report here (and a .png plot beside it)")
    sim.add_argument("--plot", type=Path, default=None, help="where to write the velocity plot (default: beside the report)")
    sim.add_argument(
        "--hardware",
        default=None,
        help="through simulated hardware: its codecs and buses (sim-can, sim-mixed), or the G1 over DDS (sim-dds)",
    )
    sim.add_argument("--perturb", default=None, help="perturbations: a shipped set (push, rough) or a YAML (sim/perturbations.py)")
    sim.add_argument("--faults", default=None, help="with --hardware: YAML of faults to inject per bus (configs/faults/)")
    sim.add_argument("--realtime", action="store_true", help="pace simulated time to the wall clock")
    sim.add_argument("--viewer", action="store_true", help="open MuJoCo's interactive viewer (needs a display)")
    sim.add_argument("--progress", action="store_true", help="show a progress bar")
    sim.add_argument("--status", action="store_true", help="a live status line on stderr: mode, command, measured velocity, plan latency")
    sim.add_argument("--record", type=Path, default=None, help="record every tick into this MCAP file (g1ctl log reads it)")


def run(args: argparse.Namespace) -> int:
    if args.video is not None or args.picture is not None:
        from sim import use_headless_gl  # noqa: PLC0415

        use_headless_gl()  # before MuJoCo is imported, which fixes its OpenGL backend
    from controller.runtime.backend_registry import choose_backend  # noqa: PLC0415
    from controller.runtime.run_config import RunConfig  # noqa: PLC0415
    from controller.runtime.run_plan import resolve_run  # noqa: PLC0415

    choice = choose_backend(args.hardware)
    if not choice.entry.simulated:
        hardware = args.hardware
        raise ConfigError(
            f"hardware config '{hardware}' is a real robot: g1ctl sim simulates; drive it with g1ctl run --hardware {hardware}"
        )
    perturbations = None
    if args.perturb:
        from sim.perturbations import load_perturbations  # noqa: PLC0415 - MuJoCo

        perturbations = load_perturbations(args.perturb, args.seed)
    cfg = RunConfig(
        scenario=args.scenario, policy=args.policy, tracker=args.tracker, planner=args.planner, duration=args.duration, seed=args.seed,
        input=args.input,
        video=args.video, video_fps=args.video_fps, picture=args.picture, report=args.report, plot=args.plot, realtime=args.realtime,
        viewer=args.viewer, progress=args.progress, assets_dir=args.assets_dir, hardware=args.hardware, faults=args.faults,
        status=args.status, estimator=args.estimator, estimator_config=args.estimator_config, record=args.record,
        perturbations=perturbations,
    )  # fmt: skip
    return run_and_summarize(resolve_run(cfg, choice))


def run_and_summarize(plan: RunPlan, hooks: RunHooks | None = None) -> int:
    """Run (with a job's `hooks`: instructions given while it runs), print the summary and where the outputs are; exit
    status 1 when the run ended damped by a fault."""
    from controller.runtime.driver import execute  # noqa: PLC0415

    report = execute(plan, hooks)
    summary_keys = ("run_seconds", "real_time_factor", "falls", "velocity_error_mean", "yaw_rate_error_mean", "policy_step_ms", "overruns")
    print(json.dumps({k: report[k] for k in summary_keys if k in report}))
    if "plan_latency_ms" in report:
        print(json.dumps({k: report[k] for k in ("plan_latency_ms", "replans", "late_plans", "planner_failures") if k in report}))
    if "instructions" in report:
        said = ("received", "accepted", "refused", "cancelled", "stops", "dropped_messages", "first_plan_latency_s")
        print(json.dumps({"instructions": {k: report["instructions"][k] for k in said}}))
    for key in ("video", "picture", "plot"):
        if key in report:
            print(f"{key}: {report[key]}")
    if "recorder" in report:
        recorder = report["recorder"]
        print(f"recording: {recorder['path']} ({recorder['messages']} messages, {recorder['drops']} ticks dropped)")
    if plan.outputs.report:
        print(f"report: {plan.outputs.report}")
    if "hw" in report:
        hw = report["hw"]
        keys = ("cycle_ms", "frames_sent", "frames_received", "dropped", "commands_sent", "states_received", "crc_errors", "faults")
        print(json.dumps({"hw": {k: hw[k] for k in keys if k in hw}}))
    faulted = print_fault_ending(report)
    if "drill" in report:  # a drill: the fault was the point, its verdict is the exit status
        print(drill_line(report["drill"]))
        return 0 if report["drill"]["passed"] else 1
    return 1 if faulted else 0


def print_fault_ending(report: dict[str, Any]) -> bool:
    """One line on stderr when the run ended damped by a fault; True then (the exit status is 1)."""
    faulted = bool(report["final_mode"] == "damp" and report["damp_reason"].startswith("fault"))
    if faulted:
        print(f"g1ctl: run ended damped at {report['damp_time']} s: {report['damp_reason']}", file=sys.stderr)
    return faulted


def drill_line(drill: dict[str, Any]) -> str:
    """`drill PLAN: passed|FAILED: what happened` in one line."""
    latency = drill.get("damping_latency_s")
    did = (
        f"every motor safe {1e3 * latency:.0f} ms after the fault (stated {1e3 * drill['within_s']:.0f} ms)" if latency is not None else ""
    )
    did = did or {"ride-through": "rode through", "clamped": "clamped"}.get(drill["expected"], drill["expected"])
    wire = f"{drill['outside_limits']} commands outside the limits on the wire"
    verdict = "passed" if drill["passed"] else f"FAILED: {'; '.join(drill['failures'])}"
    return f"drill {drill['plan']}: {verdict} ({did}; {wire})"
