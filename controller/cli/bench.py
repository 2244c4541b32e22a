"""`g1ctl bench ...`: benchmarks, each printing and writing a JSON report.

g1ctl bench loop [--report PATH] [--policy NAME] [--rounds N] [--duration S] [--estimator]
g1ctl bench recorder [--report PATH] [--duration 60] [--rounds 2] [--hardware sim-can] [--keep DIR]
g1ctl bench estimator [--report PATH] [--backends sim-can,sim-dds] [--cases NAMES] [--seed 1]
g1ctl bench hw [--report PATH] [--seconds 60] [--rt-priority 50] [--cpu N]
g1ctl bench dds [--report PATH] [--seconds 30] [--rt-priority 50] [--cpu N] [--hardware sim-dds]
g1ctl bench buses [--report PATH] [--rates 250,333.333,400,500] [--seconds 10] [--hardware sim-can-process] [--rt-priority N]
                  [--cpu N]
g1ctl bench inbetween --data PATH [--methods ours,interp,hermite,zerovel,ours_vel] [--lengths 15,30,45] [--windows N] [--seed S]
                      [--temperature T] [--residual-gain G] [--split test|val|all] [--only STYLE]
                      --report PATH
g1ctl bench caption [--data PATH] [--model DIR] [--seeds 8] [--windows 200] --report PATH
g1ctl bench text [--suite configs/prompts/suite.yaml] [--report PATH] [--seed S] [--limit N] [--no-kinematic] [--text] [--text-slot]
g1ctl bench gestures --data PATH [--data PATH ...] [--report PATH]     (--run-prompts DIR --seed S: executed clauses to score)
                 [--hardware sim-can]
g1ctl bench typed [--instructions 20] [--refused 2] [--seed 0] [--min-gap 0.5] [--max-gap 3.0] [--hardware sim-can] [--report PATH]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from controller.reports import write_report
from hw.errors import ConfigError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    bench = sub.add_parser("bench", help="benchmarks (reports in JSON)")
    bench_sub = bench.add_subparsers(dest="bench_command", required=True)
    loop = bench_sub.add_parser("loop", help="stack real-time factor against a minimal inline loop")
    loop.add_argument("--report", type=Path, default=None)
    loop.add_argument("--policy", default="fastsac")
    loop.add_argument("--rounds", type=int, default=3, help="alternating runs of each loop")
    loop.add_argument("--duration", type=float, default=20.0)
    loop.add_argument("--estimator", action="store_true", help="the stack runs the state estimator, as on hardware")

    recorder = bench_sub.add_parser("recorder", help="the flight recorder's cost to the loop (recording on against off) and its drops")
    recorder.add_argument("--report", type=Path, default=None)
    recorder.add_argument("--duration", type=float, default=60.0, help="simulated seconds of each run")
    recorder.add_argument("--rounds", type=int, default=2, help="alternating runs of each, off then on")
    recorder.add_argument("--policy", default="fastsac")
    recorder.add_argument("--hardware", default=None, help="through simulated hardware (sim-can, sim-mixed); default: the simulator")
    recorder.add_argument("--keep", type=Path, default=None, help="keep the recordings in this folder")

    estimator = bench_sub.add_parser("estimator", help="the state estimator against the simulator's truth: drift, heading, velocity, cost")
    estimator.add_argument("--report", type=Path, default=None)
    estimator.add_argument("--backends", default="sim-can,sim-dds", help="comma-separated: sim (the simulator) or hardware configs")
    estimator.add_argument("--cases", default=None, help="comma-separated case names (default: all; see the printed table)")
    estimator.add_argument("--seed", type=int, default=1)

    hw_bench = bench_sub.add_parser("hw", help="host bus cycle at 500 Hz against a raw python-can round trip, both in every period")
    hw_bench.add_argument("--report", type=Path, default=None)
    hw_bench.add_argument("--seconds", type=float, default=60.0)
    hw_bench.add_argument("--rt-priority", type=int, default=50, help="SCHED_FIFO priority for both loops (0: normal scheduling)")
    hw_bench.add_argument("--cpu", type=int, default=None, help="pin both loops to this CPU (default: the last one; -1: no pinning)")

    buses = bench_sub.add_parser("buses", help="the bus rates this machine holds against the bus robot in its own process")
    buses.add_argument("--report", type=Path, default=None)
    buses.add_argument("--rates", default="250,333.333,400,500", help="comma-separated bus rates to try (Hz)")
    buses.add_argument("--seconds", type=float, default=10.0, help="seconds at each rate")
    buses.add_argument("--hardware", default="sim-can-process", help="a bus robot's config (robot_process: true)")
    buses.add_argument("--rt-priority", type=int, default=0, help="SCHED_FIFO priority of the host loop (0: normal scheduling)")
    buses.add_argument("--cpu", type=int, default=None, help="pin the host loop to this CPU (default: no pinning)")

    dds_bench = bench_sub.add_parser("dds", help="host cycle with the G1 over DDS at 500 Hz against a raw Cyclone DDS round trip")
    dds_bench.add_argument("--report", type=Path, default=None)
    dds_bench.add_argument("--seconds", type=float, default=30.0)
    dds_bench.add_argument("--rt-priority", type=int, default=50, help="SCHED_FIFO priority of the host loop (0: normal scheduling)")
    dds_bench.add_argument("--cpu", type=int, default=None, help="pin the host loop to this CPU (default: the last one; -1: no pinning)")
    dds_bench.add_argument("--hardware", default="sim-dds", help="a simulated DDS hardware config (its domain and interface)")

    inbetween = bench_sub.add_parser("inbetween", help="motion in-betweening on held-out clips: the planner against baselines")
    inbetween.add_argument("--data", type=Path, default=None, help="recorded motion dataset (its test split is used)")
    inbetween.add_argument(
        "--methods", default="ours,interp,hermite,zerovel", help="comma-separated: ours, interp, hermite, zerovel, ours_vel"
    )
    inbetween.add_argument("--lengths", default="15,30,45", help="comma-separated transition lengths (frames at 30 fps)")
    inbetween.add_argument("--windows", type=int, default=200, help="windows per length, at most")
    inbetween.add_argument("--seed", type=int, default=0)
    inbetween.add_argument("--model", type=Path, default=None, help="planner model folder for 'ours' (default: the shipped one)")
    inbetween.add_argument("--temperature", type=float, default=None, help="ours: sampling noise scale (default: the model's)")
    inbetween.add_argument(
        "--residual-gain",
        type=float,
        default=None,
        help="ours: share of the learned residual added to the anchor, 0-1, with or without keyframe velocities (default: the model's)",
    )
    inbetween.add_argument(
        "--split", default="test", choices=("test", "val", "all"), help="held-out split (choose settings on val only; all: with --only)"
    )
    inbetween.add_argument(
        "--only", default=None, help="score only clips of these styles, e.g. bonus or 'dance-B_*' (comma-separated; see --hold-out)"
    )
    inbetween.add_argument("--report", type=Path, default=None)

    text = bench_sub.add_parser("text", help="a suite of typed prompts run on the simulated G1: pass/fail, order, transitions")
    text.add_argument("--suite", type=Path, default=None, help="prompt suite YAML (default: the shipped configs/prompts/suite.yaml)")
    text.add_argument("--report", type=Path, default=None)
    text.add_argument("--seed", type=int, default=0)
    text.add_argument("--policy", default="fastsac")
    text.add_argument("--limit", type=int, default=None, help="only the first N prompts")
    text.add_argument("--no-kinematic", action="store_true", help="skip the blended-against-baselines comparison on the composed plans")
    text.add_argument("--text", action="store_true", help="put each clause's text in the planner's text slot (off by default)")
    text.add_argument(
        "--text-slot", action="store_true", help="also measure how much each clause's text changes the composed plan (against a seed)"
    )
    text.add_argument("--hardware", default=None, help="run each prompt through simulated hardware (sim-can, sim-dds): the estimate steers")
    typed = bench_sub.add_parser(
        "typed", help="instructions sent through the local socket at random times to a wall-clock simulated run: latency, falls"
    )
    typed.add_argument("--instructions", type=int, default=20, help="how many the script sends")
    typed.add_argument("--refused", type=int, default=2, help="how many of them the planner must refuse")
    typed.add_argument("--seed", type=int, default=0, help="the script's texts and times, and the run's seed")
    typed.add_argument("--min-gap", type=float, default=0.5, help="seconds between two sends, at least")
    typed.add_argument("--max-gap", type=float, default=3.0, help="seconds between two sends, at most")
    typed.add_argument("--policy", default="fastsac")
    typed.add_argument("--hardware", default=None, help="through simulated hardware (sim-can, sim-mixed); default: the simulator")
    typed.add_argument("--report", type=Path, default=None)
    gestures = bench_sub.add_parser("gestures", help="the arm gesture detector's recall and precision on labelled executed motion")
    gestures.add_argument("--data", type=Path, action="append", default=[], help="a recorded dataset or a folder of executed clauses")
    gestures.add_argument("--run-prompts", type=Path, default=None, help="run the bench's prompts on the simulator, keep the clauses here")
    gestures.add_argument("--seed", type=int, default=0, help="with --run-prompts: the simulation seed")
    gestures.add_argument("--policy", default="fastsac", help="with --run-prompts: locomotion policy preset of the tracker")
    gestures.add_argument("--report", type=Path, default=None)
    caption = bench_sub.add_parser("caption", help="how captions change the planner's plans (text conditioning)")
    caption.add_argument("--data", type=Path, default=None, help="recorded dataset: captioned test windows (default: standing only)")
    caption.add_argument("--model", type=Path, default=None, help="planner model folder (default: the shipped one)")
    caption.add_argument("--seeds", type=int, default=8, help="plans per caption and context")
    caption.add_argument("--windows", type=int, default=200, help="captioned test windows, at most")
    caption.add_argument("--length", type=int, default=44, help="plan length in frames (multiple of 4, 24-64)")
    caption.add_argument("--seed", type=int, default=0)
    caption.add_argument("--report", type=Path, default=None)


def run(args: argparse.Namespace) -> int:
    if args.bench_command == "hw":
        from controller.bench.hw import run_hw_bench  # noqa: PLC0415

        _emit(run_hw_bench(args.seconds, args.rt_priority, args.cpu), args.report)
        return 0
    if args.bench_command == "buses":
        from controller.bench.bus_robot import run_bus_robot_bench  # noqa: PLC0415

        try:
            rates = [float(rate) for rate in args.rates.split(",")]
        except ValueError:
            rates = []
        if not rates or min(rates) <= 0:
            raise ConfigError(f"--rates: positive rates in Hz, comma-separated (e.g. 250,500), got '{args.rates}'")
        _emit(run_bus_robot_bench(rates, args.seconds, args.hardware, args.rt_priority, args.cpu, args.assets_dir), args.report)
        return 0
    if args.bench_command == "dds":
        from controller.bench.dds import run_dds_bench  # noqa: PLC0415 - the g1 extra

        _emit(run_dds_bench(args.seconds, args.rt_priority, args.cpu, args.hardware, args.assets_dir), args.report)
        return 0
    if args.bench_command == "inbetween":
        return _inbetween(args)
    if args.bench_command == "text":
        return _text(args)
    if args.bench_command == "caption":
        return _caption(args)
    if args.bench_command == "typed":
        return _typed(args)
    if args.bench_command == "gestures":
        return _gestures(args)
    if args.bench_command == "estimator":
        return _estimator(args)
    if args.bench_command == "recorder":
        from controller.bench.recorder import run_recorder_bench  # noqa: PLC0415 - imports MuJoCo

        report = run_recorder_bench(args.duration, args.rounds, args.hardware, args.policy, args.assets_dir, args.keep)
        _emit(report, args.report)
        return 0 if report["targets_met"] else 1
    from controller.bench.loop import run_loop_bench  # noqa: PLC0415 - imports MuJoCo

    _emit(run_loop_bench(args.policy, args.rounds, args.duration, args.assets_dir, args.estimator), args.report)
    return 0


def _inbetween(args: argparse.Namespace) -> int:
    from controller.bench import inbetween as bi  # noqa: PLC0415
    from controller.motion_data.styles import parse_patterns  # noqa: PLC0415

    if args.data is None:
        raise ConfigError("bench inbetween needs --data PATH: a recorded motion dataset")
    cfg = bi.InbetweenConfig(
        data=args.data, methods=bi.parse_methods(args.methods), lengths=bi.parse_lengths(args.lengths), windows=args.windows,
        seed=args.seed, assets_dir=args.assets_dir, model_dir=args.model, temperature=args.temperature, split=args.split,
        residual_gain=args.residual_gain, only=() if args.only is None else parse_patterns(args.only, "--only"),
    )  # fmt: skip
    report = bi.run_inbetween_bench(cfg)
    print(bi.format_table(report))
    _save(report, args.report)
    return 0


def _text(args: argparse.Namespace) -> int:
    import sys  # noqa: PLC0415

    from controller.bench.text import TextBenchConfig, run_text_bench  # noqa: PLC0415
    from controller.runtime.backend_registry import choose_backend  # noqa: PLC0415
    from controller.text.service import TextPlanner  # noqa: PLC0415

    hardware = choose_backend(args.hardware) if args.hardware is not None else None  # loaded once for every prompt's run
    if hardware is not None and not hardware.entry.simulated:
        raise ConfigError(f"bench text --hardware {args.hardware}: a real robot; the suite runs on simulated hardware (sim-can, sim-dds)")
    cfg = TextBenchConfig(
        suite=args.suite, seed=args.seed, policy=args.policy, limit=args.limit, kinematic=not args.no_kinematic, text_slot=args.text_slot
    )
    planner = TextPlanner.load(condition_text=args.text)
    report = run_text_bench(
        cfg,
        planner.resolve,
        lambda program: planner.simulate(program, seed=args.seed, policy=args.policy, hardware=hardware),
        lambda program, blend, continue_motion: planner.composed_transition(program, blend, args.seed, continue_motion),
        progress=lambda line: print(line, file=sys.stderr, flush=True),
        frames=planner.composed_frames,
    )
    report["hardware"] = args.hardware  # None: the simulator directly
    print(json.dumps({k: v for k, v in report.items() if k != "results"}, indent=2))
    _save(report, args.report)
    return 0


def _typed(args: argparse.Namespace) -> int:
    from controller.bench.typed import TypedBenchConfig, run_typed_bench  # noqa: PLC0415 - imports MuJoCo
    from controller.runtime.backend_registry import choose_backend  # noqa: PLC0415

    if args.hardware is not None and not choose_backend(args.hardware).entry.simulated:
        raise ConfigError(f"bench typed --hardware {args.hardware}: a real robot; the bench runs on simulated hardware (sim-can)")
    cfg = TypedBenchConfig(
        instructions=args.instructions, refused=args.refused, seed=args.seed, min_gap_s=args.min_gap, max_gap_s=args.max_gap,
        policy=args.policy, hardware=args.hardware, assets_dir=args.assets_dir,
    )  # fmt: skip
    report = run_typed_bench(cfg)
    print(json.dumps({k: v for k, v in report.items() if k != "log"}, indent=2))
    _save(report, args.report)
    return 0 if report["targets_met"] else 1


def _gestures(args: argparse.Namespace) -> int:
    import sys  # noqa: PLC0415

    from controller.bench import gestures as bg  # noqa: PLC0415
    from controller.text.gesture_detector import detect_gestures  # noqa: PLC0415

    if args.run_prompts is not None:
        kept = bg.record_clauses(
            bg.PROMPTS, args.run_prompts, args.seed, args.policy, lambda line: print(line, file=sys.stderr, flush=True)
        )
        print(json.dumps({"out": str(args.run_prompts), "clauses": kept, "seed": args.seed}))
        return 0
    if not args.data:
        raise ConfigError("bench gestures needs --data PATH (a recorded dataset or executed clauses) or --run-prompts DIR")
    report = bg.run_gesture_bench(args.data, detect_gestures)
    print(bg.format_table(report))
    _save(report, args.report)
    return 0


def _estimator(args: argparse.Namespace) -> int:
    import sys  # noqa: PLC0415

    from controller.bench import estimator as be  # noqa: PLC0415 - imports MuJoCo

    cases = be.select_cases(args.backends.split(","), args.cases.split(",") if args.cases else None)
    report = be.run_estimator_bench(cases, args.seed, args.assets_dir, progress=lambda line: print(line, file=sys.stderr, flush=True))
    print(be.format_table(report))
    _save(report, args.report)
    return 0 if report["targets_met"] else 1


def _caption(args: argparse.Namespace) -> int:
    from controller.bench import captions as bc  # noqa: PLC0415

    cfg = bc.CaptionConfig(
        data=args.data, model_dir=args.model, seeds=args.seeds, windows=args.windows, length=args.length, seed=args.seed,
        assets_dir=args.assets_dir,
    )  # fmt: skip
    report = bc.run_caption_bench(cfg)
    print(bc.format_table(report))
    _save(report, args.report)
    return 0


def _save(report: dict[str, Any], path: Path | None) -> None:
    """Write the JSON report where asked and say where."""
    if path is not None:
        write_report(report, path)
        print(f"report: {path}")


def _emit(report: dict[str, Any], path: Path | None) -> None:
    print(json.dumps(report, indent=2))
    if path is not None:
        write_report(report, path)
