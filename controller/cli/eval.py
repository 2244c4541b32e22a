"""`g1ctl eval --suite smoke|robustness|faults|PATH [--workers N] [--address ADDR] [--report PATH] [--progress]
[--first-seed N] [--seeds N] [--hardware CONFIG] [--against REPORT]`: a sweep.

Every episode of the suite (`controller/eval/suite.py`) runs on the simulator or simulated
hardware, in this process (`--workers 1`) or as Ray tasks (a local instance with N CPUs that
starts and stops with the command, or the cluster at `--address`). The report (JSON, with a
journal beside it that lets an interrupted sweep resume) gives per condition the episodes,
falls, survival with its 95 % interval and the velocity error, and for fault drills their
verdicts; the exit status is 1 when a condition misses the suite's criteria or a drill fails.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from hw.errors import ConfigError

if TYPE_CHECKING:
    from controller.eval.suite import SuiteConfig


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    ev = sub.add_parser("eval", help="a robustness sweep: a suite of episodes, locally or on Ray, into one report")
    ev.add_argument("--suite", required=True, help="a shipped suite (smoke) or a suite YAML")
    ev.add_argument("--workers", type=int, default=1, help="Ray workers (1: in this process, no Ray)")
    ev.add_argument("--address", default=None, help="join this Ray cluster (e.g. auto, or HOST:6379) instead of starting one")
    ev.add_argument("--report", type=Path, default=None, help="JSON report; its journal REPORT.jsonl lets a sweep resume")
    ev.add_argument("--progress", action="store_true", help="a progress bar on stderr")
    ev.add_argument("--against", type=Path, default=None, help="an earlier report (other seeds): name the conditions that do not hold")
    ev.add_argument("--first-seed", type=int, default=None, help="run the suite's episodes from this seed on (a re-run with other seeds)")
    ev.add_argument("--seeds", type=int, default=None, help="seeds per condition instead of the suite's")
    ev.add_argument(
        "--hardware", default=None, metavar="CONFIG",
        help="run the suite's perturbed episodes through this simulated hardware (e.g. sim-can) instead of the suite's",
    )  # fmt: skip


def with_hardware(suite: SuiteConfig, hardware: str) -> SuiteConfig:
    """The suite through other simulated hardware; refused in one line for a real robot's config or one that cannot be perturbed."""
    from hw.dds.config import DdsHardwareConfig  # noqa: PLC0415
    from hw.jointmap import load_robot_config  # noqa: PLC0415

    cfg = load_robot_config(hardware)
    if not cfg.simulated:
        raise ConfigError(f"--hardware {hardware} is a real robot's config: an evaluation runs on simulated hardware")
    if isinstance(cfg, DdsHardwareConfig):
        raise ConfigError(
            f"--hardware {hardware}: perturbations need the physics in this process: give simulated buses (sim-can, sim-mixed)"
        )
    return dataclasses.replace(suite, hardware=(hardware,))


def run(args: argparse.Namespace) -> int:
    from controller.eval.runner import EvalConfig, run_suite  # noqa: PLC0415 - imports MuJoCo
    from controller.eval.suite import load_suite  # noqa: PLC0415

    suite = load_suite(args.suite)
    if args.first_seed is not None:
        suite = dataclasses.replace(suite, first_seed=args.first_seed)
    if args.seeds is not None:
        suite = dataclasses.replace(suite, seeds=args.seeds)
    if args.hardware is not None:
        suite = with_hardware(suite, args.hardware)
    report = run_suite(EvalConfig(suite, args.suite, args.workers, args.address, args.report, args.progress, args.assets_dir))
    for group, figures in report["conditions"].items():
        keys: tuple[str, ...] = ("episodes", "falls", "survival", "survival_ci95", "velocity_error_mean", "outside_limits")
        if "drills" in figures:  # a drill: what it is judged on
            keys = ("episodes", "drills_passed", "damping_latency_max_s", "within_s", "outside_limits")
        print(json.dumps({"condition": group} | {k: figures[k] for k in keys if k in figures}))
    print(json.dumps({"wall_seconds": report["wall_seconds"], "episodes_run": report["episodes_run"], "workers": report["workers"]}))
    if args.report:
        print(f"report: {args.report}")
    if args.against is not None:
        from controller.eval.stats import disagreements  # noqa: PLC0415

        earlier = json.loads(args.against.read_text())["conditions"]
        differ = disagreements(earlier, report["conditions"])
        print(json.dumps({"against": str(args.against), "conditions_compared": len(set(earlier) & set(report["conditions"])),
                          "outside_the_other_runs_interval": differ}))  # fmt: skip
    for failure in report["criteria_failures"]:
        print(f"g1ctl: criterion missed: {failure}", file=sys.stderr)
    return 1 if report["criteria_failures"] else 0
