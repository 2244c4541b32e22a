"""Run a suite's episodes, in this process or as Ray tasks, into one report; an interrupted sweep resumes.

Each episode is one `g1ctl sim` run (`runtime/driver.py`, `run`) from its own seed, so its result does not
depend on where or in what order it ran. Results are appended to a journal (`REPORT.jsonl`) as
they finish; a second run of the same suite and report skips the episodes already there. With
Ray, a task whose worker dies is retried once, then reported as failed, never dropped.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from controller.eval.executor import Executor, TaskLost
from controller.eval.html import write_html
from controller.eval.stats import push_curves, summarize
from controller.eval.suite import EpisodeSpec, SuiteConfig, episodes
from controller.reports import write_report
from sim.perturbations import Perturbations


@dataclass(frozen=True)
class EvalConfig:
    suite: SuiteConfig
    suite_name: str
    workers: int = 1  # 1 without an address: in this process, no Ray
    address: str | None = None  # an existing Ray cluster ("auto", "ray://host:10001", ...)
    report: Path | None = None
    progress: bool = False
    assets_dir: str | None = None


def episode_cpus(hardware: str) -> int:
    """CPUs an episode holds: two when its robot runs in a process of its own on the wall clock (a simulated G1 over
    DDS), so that the host and the robot each have one; a starved robot goes quiet for 50 ms and the host rightly damps."""
    if hardware == "none":
        return 1
    from hw.dds.config import DdsHardwareConfig  # noqa: PLC0415
    from hw.jointmap import load_robot_config  # noqa: PLC0415

    return 2 if isinstance(load_robot_config(hardware), DdsHardwareConfig) else 1


def run_episode(episode: EpisodeSpec, assets_dir: str | None = None) -> dict[str, Any]:
    """One episode on the simulator; any exception is the episode's failure, reported, not raised."""
    from controller.runtime.driver import run  # noqa: PLC0415 - MuJoCo (the simulator's builders), in the worker
    from controller.runtime.run_config import RunConfig  # noqa: PLC0415

    base = {"id": episode.id, "group": episode.group, "condition": episode.condition, "seed": episode.seed}
    perturbed = episode.perturbations if episode.perturbations != Perturbations() else None
    cfg = RunConfig(
        scenario=episode.scenario, policy=episode.policy, planner=episode.planner, duration=episode.duration_s, seed=episode.seed,
        tracker=None if episode.tracker == "default" else episode.tracker,
        hardware=None if episode.hardware == "none" else episode.hardware, perturbations=perturbed, assets_dir=assets_dir,
        faults=episode.faults,
    )  # fmt: skip
    t0 = time.perf_counter()
    try:
        report = run(cfg)
    except Exception as exc:  # the episode failed; the sweep goes on and says so
        return base | {"status": "failed", "error": f"{type(exc).__name__}: {exc}", "trace": traceback.format_exc(limit=3)}
    return base | {
        "status": "done",
        "falls": report["falls"],
        "velocity_error_mean": report["velocity_error_mean"],
        "final_mode": report["final_mode"],
        "damp_reason": report["damp_reason"],
        "ended_in_fault": report["final_mode"] == "damp" and report["damp_reason"].startswith("fault"),  # not survived
        "push_impulse_ns": report.get("push_impulse_ns", 0.0),
        # On the push curve: a condition that only pushes, at one impulse (not drawn from a range).
        "pushes_only": not episode.randomized and dataclasses.replace(episode.perturbations, pushes=None) == Perturbations(),
        "pushes": len(report.get("pushes", [])),
        "perturbations": dataclasses.asdict(episode.perturbations) if episode.randomized else None,  # as drawn
        "outside_limits": report["hw"]["wire"]["outside_limits"] if "wire" in report.get("hw", {}) else None,  # on the wire
        "drill": _drill_summary(report["drill"]) if "drill" in report else None,
        "episode_seconds": round(time.perf_counter() - t0, 3),
    }


def _drill_summary(drill: dict[str, Any]) -> dict[str, Any]:
    keys = ("passed", "expected", "fault_at_s", "within_s", "damping_latency_s", "outside_limits", "failures", "faults")
    return {k: drill[k] for k in keys if k in drill}


def run_suite(cfg: EvalConfig) -> dict[str, Any]:
    """Every episode not yet in the journal, then the report over all of them."""
    every = episodes(cfg.suite, cfg.suite_name)
    journal = cfg.report.with_suffix(".jsonl") if cfg.report is not None else None
    finished = _read_journal(journal) if journal is not None else {}
    todo = [e for e in every if e.id not in finished]
    t0 = time.perf_counter()
    with tqdm(total=len(every), initial=len(every) - len(todo), unit="episode", disable=not cfg.progress, file=sys.stderr) as bar:

        def record(result: dict[str, Any]) -> None:
            finished[result["id"]] = result
            if journal is not None:
                journal.parent.mkdir(parents=True, exist_ok=True)
                with journal.open("a") as out:
                    out.write(json.dumps(result) + "\n")
            bar.update(1)

        with Executor(cfg.workers, cfg.address) as executor:
            cpus = [episode_cpus(e.hardware) for e in todo]
            for index, result in executor.map_unordered(run_episode, [(e, cfg.assets_dir) for e in todo], cpus):
                if isinstance(result, TaskLost):  # the worker died twice: the episode is lost, and says so
                    episode = todo[index]
                    base = {"id": episode.id, "group": episode.group, "condition": episode.condition, "seed": episode.seed}
                    result = base | {"status": "failed", "error": str(result)}
                record(result)
            swept = time.perf_counter() - t0  # the sweep, Ray's start included, up to its last result (not Ray's teardown)
    results = [finished[e.id] for e in every]
    conditions = summarize(results)
    report: dict[str, Any] = {
        "suite": cfg.suite_name,
        "description": cfg.suite.description,
        "workers": cfg.workers,
        "address": cfg.address,
        "wall_seconds": round(swept + _earlier_wall_seconds(cfg.report, len(every) - len(todo)), 3),
        "episodes_run": len(todo),
        "episodes_resumed": len(every) - len(todo),
        "conditions": conditions,
        "push_curves": push_curves(conditions),
        "episodes": results,
    }
    report["criteria_failures"] = safety_failures(conditions) + criteria_failures(cfg.suite, conditions)
    if cfg.report is not None:
        write_report(report, cfg.report)
        write_html(report, cfg.report.with_suffix(".html"))
    return report


def criteria_failures(suite: SuiteConfig, conditions: dict[str, dict[str, Any]]) -> list[str]:
    """One line per condition that misses its criteria."""
    failures = []
    for group, figures in conditions.items():
        criteria = suite.criteria.get(figures["condition"])
        if criteria is None:
            continue
        if figures["survival"] is not None and figures["survival"] < criteria.min_survival:
            failures.append(f"{group}: survival {figures['survival']:.2f} < {criteria.min_survival:.2f}")
        error = figures["velocity_error_mean"]
        if criteria.max_velocity_error is not None and error is not None and error > criteria.max_velocity_error:
            failures.append(f"{group}: velocity error {error:.3f} m/s > {criteria.max_velocity_error:.3f}")
    return failures


def safety_failures(conditions: dict[str, dict[str, Any]]) -> list[str]:
    """What no suite may waive: an episode that could not run, a drill that did not do what its plan expects, a command
    outside the limits on the wire."""
    failures = []
    for group, figures in conditions.items():
        if figures["failed_episodes"]:
            failures.append(f"{group}: {figures['failed_episodes']} episodes failed to run")
        for line in figures.get("drill_failures", []):
            failures.append(f"{group}: drill failed: {line}")
        if figures.get("outside_limits"):
            failures.append(f"{group}: {figures['outside_limits']} commands outside the joint limits reached the motors")
    return failures


def _earlier_wall_seconds(report: Path | None, resumed: int) -> float:
    """A resumed sweep's wall time includes the earlier calls' (as their report gave it; 0 when it was never written)."""
    if report is None or resumed == 0 or not report.is_file():
        return 0.0
    try:
        return float(json.loads(report.read_text()).get("wall_seconds", 0.0))
    except (ValueError, TypeError):
        return 0.0


def _read_journal(path: Path) -> dict[str, dict[str, Any]]:
    """Finished episodes of an earlier, interrupted run (a torn last line is ignored: that episode runs again)."""
    if not path.is_file():
        return {}
    finished = {}
    for line in path.read_text().splitlines():
        try:
            result = json.loads(line)
        except json.JSONDecodeError:
            continue
        if result.get("status") == "done":
            finished[result["id"]] = result
    return finished
