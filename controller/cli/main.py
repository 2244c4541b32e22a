"""g1ctl: command line of the G1 controller stack.

Usage:
    g1ctl sim --scenario walk_turn_stop [--policy fastsac] [--duration S] [--seed N]
              [--video runs/demo.mp4] [--picture last.png] [--report runs/report.json] [--realtime] [--viewer]
              [--input scripted|keyboard|gamepad] [--hardware sim-can|sim-mixed|PATH] [--progress]
    g1ctl assets fetch [--assets-dir DIR]
    g1ctl bench loop [--report PATH] [--policy NAME] [--rounds N]
    g1ctl bench hw [--report PATH] [--seconds 60]
    g1ctl bench inbetween --data PATH [--methods ours,interp,hermite,zerovel] [--lengths 15,30,45] [--windows N] [--seed S] --report PATH
    g1ctl hw scan|monitor|zero|sweep|damp|imu --hardware NAME   (bench bring-up, see hw_commands)
    g1ctl hw frame encode|decode --protocol mit|unitree-rs485 ...
    g1ctl dataset record|import|info ...   (the planner's motion dataset, see dataset_commands)
    g1ctl scenarios            (list the shipped scenarios, policies and hardware configs)

Every command that needs the G1 model or policies fetches them first (see `g1ctl assets`).
A mistake in the input ends with one line on stderr and exit status 2; a fault during
a run with exit status 1.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from hw.errors import ConfigError, G1Error, HardwareFault


def _build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="g1ctl", description="Unitree G1 controller stack")
    parser.add_argument("--assets-dir", default=None, help="verified local copies of the assets (also G1CTL_ASSETS_DIR)")
    sub = parser.add_subparsers(dest="command", required=True)

    sim = sub.add_parser("sim", help="run a command scenario on the simulated G1")
    sim.add_argument("--scenario", default="walk_turn_stop", help="shipped scenario name or path to a scenario YAML")
    sim.add_argument("--policy", default="fastsac", help="policy preset name or path to a policy YAML")
    sim.add_argument("--duration", type=float, default=None, help="seconds of simulated time (default: the scenario's)")
    sim.add_argument("--seed", type=int, default=0)
    sim.add_argument("--input", default="scripted", choices=("scripted", "keyboard", "gamepad"))
    sim.add_argument("--video", type=Path, default=None, help="write an .mp4 or .gif of the run")
    sim.add_argument("--video-fps", type=int, default=20)
    sim.add_argument("--picture", type=Path, default=None, help="write a .png of the final frame")
    sim.add_argument("--report", type=Path, default=None, help="write the JSON report here (and a .png plot beside it)")
    sim.add_argument("--plot", type=Path, default=None, help="where to write the velocity plot (default: beside the report)")
    sim.add_argument("--hardware", default=None, help="drive the sim through a hardware config's codecs and buses (sim-can, sim-mixed)")
    sim.add_argument("--faults", default=None, help="with --hardware: YAML of faults to inject per bus (configs/faults/)")
    sim.add_argument("--realtime", action="store_true", help="pace simulated time to the wall clock")
    sim.add_argument("--viewer", action="store_true", help="open MuJoCo's interactive viewer (needs a display)")
    sim.add_argument("--progress", action="store_true", help="show a progress bar")

    assets = sub.add_parser("assets", help="manage the G1 model and policy files")
    assets_sub = assets.add_subparsers(dest="assets_command", required=True)
    assets_sub.add_parser("fetch", help="download and verify the assets (no work when already there)")
    assets_sub.add_parser("path", help="print where the assets are")

    bench = sub.add_parser("bench", help="benchmarks (reports in JSON)")
    bench_sub = bench.add_subparsers(dest="bench_command", required=True)
    loop = bench_sub.add_parser("loop", help="stack real-time factor against a minimal inline loop")
    loop.add_argument("--report", type=Path, default=None)
    loop.add_argument("--policy", default="fastsac")
    loop.add_argument("--rounds", type=int, default=3, help="alternating runs of each loop")
    loop.add_argument("--duration", type=float, default=20.0)

    hw_bench = bench_sub.add_parser("hw", help="host bus cycle at 500 Hz against a raw python-can round trip, both in every period")
    hw_bench.add_argument("--report", type=Path, default=None)
    hw_bench.add_argument("--seconds", type=float, default=60.0)
    hw_bench.add_argument("--rt-priority", type=int, default=50, help="SCHED_FIFO priority for both loops (0: normal scheduling)")
    hw_bench.add_argument("--cpu", type=int, default=None, help="pin both loops to this CPU (default: the last one; -1: no pinning)")

    inbetween = bench_sub.add_parser("inbetween", help="motion in-betweening on held-out clips: the planner against baselines")
    inbetween.add_argument("--data", type=Path, default=None, help="recorded motion dataset (its test split is used)")
    inbetween.add_argument("--methods", default="ours,interp,hermite,zerovel", help="comma-separated: ours, interp, hermite, zerovel")
    inbetween.add_argument("--lengths", default="15,30,45", help="comma-separated transition lengths (frames at 30 fps)")
    inbetween.add_argument("--windows", type=int, default=200, help="windows per length, at most")
    inbetween.add_argument("--seed", type=int, default=0)
    inbetween.add_argument("--model", type=Path, default=None, help="planner model folder for 'ours' (default: models/planner)")
    inbetween.add_argument("--report", type=Path, default=None)

    sub.add_parser("scenarios", help="list shipped scenarios, policy presets and hardware configs")

    from controller.cli.hw import add_hw_parser  # noqa: PLC0415 - keeps `g1ctl --help` import-light

    add_hw_parser(sub)
    from controller.cli.planner import add_planner_parsers  # noqa: PLC0415

    add_planner_parsers(sub)
    from controller.cli.dataset import add_dataset_parser  # noqa: PLC0415

    add_dataset_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _build_parser().parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="g1ctl: %(message)s")
    try:
        return _dispatch(args)
    except HardwareFault as exc:  # the run started and ended in a latched fault: not a usage mistake
        print(f"g1ctl: fault: {exc}", file=sys.stderr)
        return 1
    except G1Error as exc:
        print(f"g1ctl: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("g1ctl: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


def _dispatch(args: argparse.Namespace) -> int:
    if args.command == "sim":
        return _sim(args)
    if args.command == "hw":
        from controller.cli.hw import run_hw  # noqa: PLC0415

        return run_hw(args)
    if args.command == "dataset":
        from controller.cli.dataset import run_dataset  # noqa: PLC0415

        return run_dataset(args)
    if args.command in ("train", "viz"):
        from controller.cli import planner as planner_commands  # noqa: PLC0415

        return planner_commands.run_train(args) if args.command == "train" else planner_commands.run_viz(args)
    if args.command == "assets":
        from controller.assets import ensure_assets  # noqa: PLC0415

        found = ensure_assets(args.assets_dir)
        print(found.root)
        return 0
    if args.command == "bench" and args.bench_command == "hw":
        from controller.bench.hw import run_hw_bench  # noqa: PLC0415

        _emit(run_hw_bench(args.seconds, args.rt_priority, args.cpu), args.report)
        return 0
    if args.command == "bench" and args.bench_command == "inbetween":
        return _bench_inbetween(args)
    if args.command == "bench":
        from controller.bench.loop import run_loop_bench  # noqa: PLC0415

        report = run_loop_bench(args.policy, args.rounds, args.duration, args.assets_dir)
        _emit(report, args.report)
        return 0
    if args.command == "scenarios":
        from controller.inputs.scripted import available_scenarios  # noqa: PLC0415
        from controller.tracking.presets import available_policies  # noqa: PLC0415
        from hw.jointmap import available_hardware  # noqa: PLC0415

        print("scenarios:", ", ".join(available_scenarios()))
        print("policies: ", ", ".join(available_policies()))
        print("hardware: ", ", ".join(available_hardware()))
        return 0
    raise AssertionError(args.command)


def _sim(args: argparse.Namespace) -> int:
    from controller.runtime.sim_run import SimRunConfig, run  # noqa: PLC0415 - imports MuJoCo

    cfg = SimRunConfig(
        scenario=args.scenario, policy=args.policy, duration=args.duration, seed=args.seed, input=args.input,
        video=args.video, video_fps=args.video_fps, picture=args.picture, report=args.report, plot=args.plot, realtime=args.realtime,
        viewer=args.viewer, progress=args.progress, assets_dir=args.assets_dir, hardware=args.hardware, faults=args.faults,
    )  # fmt: skip
    report = run(cfg)
    summary = {
        k: report[k]
        for k in ("sim_seconds", "real_time_factor", "falls", "velocity_error_mean", "yaw_rate_error_mean", "policy_step_ms", "overruns")
    }
    print(json.dumps(summary))
    for key in ("video", "picture", "plot"):
        if key in report:
            print(f"{key}: {report[key]}")
    if args.report:
        print(f"report: {args.report}")
    if "hw" in report:
        hw = report["hw"]
        print(json.dumps({"hw": {k: hw[k] for k in ("cycle_ms", "frames_sent", "frames_received", "dropped", "crc_errors", "faults")}}))
    if report["final_mode"] == "damp" and report["damp_reason"].startswith("fault"):
        print(f"g1ctl: run ended damped: {report['damp_reason']}", file=sys.stderr)
        return 1
    return 0


def _bench_inbetween(args: argparse.Namespace) -> int:
    from controller.bench import inbetween as bi  # noqa: PLC0415 - keeps `g1ctl --help` import-light

    if args.data is None:
        raise ConfigError("bench inbetween needs --data PATH: a recorded motion dataset")
    cfg = bi.InbetweenConfig(
        data=args.data, methods=bi.parse_methods(args.methods), lengths=bi.parse_lengths(args.lengths), windows=args.windows,
        seed=args.seed, assets_dir=args.assets_dir, model_dir=args.model,
    )  # fmt: skip
    report = bi.run_inbetween_bench(cfg)
    print(bi.format_table(report))
    if args.report is not None:
        args.report.parent.mkdir(parents=True, exist_ok=True)
        args.report.write_text(json.dumps(report, indent=2) + "\n")
        print(f"report: {args.report}")
    return 0


def _emit(report: dict[str, object], path: Path | None) -> None:
    text = json.dumps(report, indent=2)
    print(text)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text + "\n")

