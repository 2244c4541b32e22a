"""`g1ctl bench text`: a suite of typed prompts run on the simulated G1, each passed or failed with its reason.

For each prompt of the suite (`configs/prompts/suite.yaml` by default): resolve it; a
prompt marked `refuse` passes when it is refused. Otherwise it runs in simulation (the
planner in the loop, blended joins) and passes when the robot did not fall, the number of
clauses is the expected one, the total displacement and heading change measured in the
start frame are within the tolerances, and every expected gesture was detected in the
executed arm motion. Then the same program runs kinematically (an ideal robot whose
root moves as commanded, no physics) twice, with blended joins and with naive concatenation, so that the two
`transition_score`s compare the composition alone.

Reported: per prompt pass/fail with the reason and the figures; the success rate; the
order accuracy of the prompts of 3 and of 4 clauses; the transition scores (simulated,
and kinematic blended against naive).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from controller.text.program import GESTURE_NAMES, Program, PromptRefused
from hw.errors import ConfigError
from hw.shipped import config_dir
from hw.yamlconfig import from_dict, load_yaml


@dataclass(frozen=True)
class Expectation:
    clauses: int | None = None
    forward_m: float = 0.0
    left_m: float = 0.0
    heading_deg: float = 0.0
    gestures: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        unknown = [g for g in self.gestures if g not in GESTURE_NAMES]
        if unknown:
            raise ConfigError(f"expected gestures {unknown} cannot be detected; use {', '.join(GESTURE_NAMES)}")


@dataclass(frozen=True)
class SuitePrompt:
    text: str
    expect: Expectation = field(default_factory=Expectation)
    refuse: bool = False
    position_tolerance_m: float | None = None
    heading_tolerance_deg: float | None = None


@dataclass(frozen=True)
class SuiteDefaults:
    position_tolerance_m: float = 0.35
    heading_tolerance_deg: float = 20.0


@dataclass(frozen=True)
class Suite:
    prompts: tuple[SuitePrompt, ...]
    defaults: SuiteDefaults = field(default_factory=SuiteDefaults)


def load_suite(path: Path | None = None) -> Suite:
    """A prompt suite from YAML (default: the shipped `configs/prompts/suite.yaml`); wrong keys name the file and the key."""
    path = path or config_dir("prompts") / "suite.yaml"
    if not path.is_file():
        raise ConfigError(f"prompt suite {path} does not exist; pass --suite PATH to a suite YAML")
    suite = from_dict(Suite, load_yaml(path), source=str(path))
    if not suite.prompts:
        raise ConfigError(f"prompt suite {path} has no prompts")
    return suite


def judge(prompt: SuitePrompt, defaults: SuiteDefaults, result: dict[str, Any]) -> tuple[bool, str]:
    """Pass or fail of one executed prompt, and why."""
    e = prompt.expect
    if result["falls"]:
        return False, f"fell {result['falls']} time(s)"
    if e.clauses is not None and result["clauses_planned"] != e.clauses:
        return False, f"planned {result['clauses_planned']} clauses, expected {e.clauses}"
    done = sum(1 for c in result["clauses"])
    if done != result["clauses_planned"]:
        return False, f"only {done} of {result['clauses_planned']} clauses ran"
    position_tol = prompt.position_tolerance_m or defaults.position_tolerance_m
    heading_tol = prompt.heading_tolerance_deg or defaults.heading_tolerance_deg
    forward, left = result["total_displacement"]
    miss = math.hypot(forward - e.forward_m, left - e.left_m)
    if miss > position_tol:
        return False, f"ended {miss:.2f} m from the expected place ({forward:.2f}, {left:.2f} against {e.forward_m}, {e.left_m})"
    heading_miss = abs(result["total_heading_change_deg"] - e.heading_deg)
    if heading_miss > heading_tol:
        return False, f"turned {result['total_heading_change_deg']:.0f} degrees, expected {e.heading_deg:.0f}"
    seen = {g for c in result["clauses"] for g in c["gestures"]}
    missing = [g for g in e.gestures if g not in seen]
    if missing:
        return False, f"gestures {missing} not seen in the arm motion (seen: {sorted(seen) or 'none'})"
    return True, "ok"


@dataclass(frozen=True)
class TextBenchConfig:
    suite: Path | None = None
    seed: int = 0
    policy: str = "fastsac"
    limit: int | None = None  # only the first N prompts (a quick look)
    kinematic: bool = True  # also compare blended with naive joins on the composed plan alone


def run_text_bench(
    cfg: TextBenchConfig,
    resolve: Callable[[str], Program],
    simulate: Callable[[Program], dict[str, Any]],
    compose: Callable[[Program, int | None], float | None],
    progress: Callable[[str], None] = lambda line: None,
) -> dict[str, Any]:
    """Run the suite: `resolve` (text -> program or PromptRefused), `simulate` (program -> text report), `compose` (kinematic score)."""
    suite = load_suite(cfg.suite)
    prompts = suite.prompts[: cfg.limit] if cfg.limit else suite.prompts
    rows = []
    started = time.perf_counter()
    for prompt in prompts:
        row: dict[str, Any] = {"text": prompt.text, "refuse": prompt.refuse}
        try:
            program = resolve(prompt.text)
        except PromptRefused as exc:
            row |= {"pass": prompt.refuse, "reason": f"refused: {exc}" if prompt.refuse else f"refused, but should run: {exc}"}
            rows.append(row)
            progress(f"{'PASS' if row['pass'] else 'FAIL'} {prompt.text!r}: {row['reason']}")
            continue
        if prompt.refuse:
            row |= {"pass": False, "reason": f"planned {len(program.clauses)} clause(s), but should be refused"}
            rows.append(row)
            progress(f"FAIL {prompt.text!r}: {row['reason']}")
            continue
        result = simulate(program)
        passed, reason = judge(prompt, suite.defaults, result)
        row |= {
            "pass": passed,
            "reason": reason,
            "clauses": len(program.clauses),
            "falls": result["falls"],
            "total_displacement": result["total_displacement"],
            "total_heading_change_deg": result["total_heading_change_deg"],
            "gestures": sorted({g for c in result["clauses"] for g in c["gestures"]}),
            "order_accuracy": result["order_accuracy"],
            "transition_score": result["transition_score"],
            "run_seconds": result["run"]["run_seconds"],
            "timed_out_clauses": sum(c["timed_out"] for c in result["clauses"]),
        }
        if cfg.kinematic and len(program.clauses) > 1:
            row["transition_kinematic_blended"] = _rounded(compose(program, 8))
            row["transition_kinematic_naive"] = _rounded(compose(program, None))
        rows.append(row)
        progress(f"{'PASS' if passed else 'FAIL'} {prompt.text!r}: {reason}")
    return summarize(rows, time.perf_counter() - started)


def summarize(rows: list[dict[str, Any]], wall_seconds: float) -> dict[str, Any]:
    """The suite's figures from its rows."""

    def mean(values: list[float]) -> float | None:
        return round(float(np.mean(values)), 4) if values else None

    ran = [r for r in rows if "clauses" in r]
    order = {n: [r["order_accuracy"] for r in ran if r["clauses"] == n] for n in (3, 4)}
    joined = [r for r in ran if "transition_kinematic_blended" in r and r["transition_kinematic_blended"] is not None]
    return {
        "prompts": len(rows),
        "passed": sum(r["pass"] for r in rows),
        "success_rate": round(sum(r["pass"] for r in rows) / len(rows), 4) if rows else None,
        "refusals_expected": sum(r["refuse"] for r in rows),
        "falls": sum(r.get("falls", 0) for r in rows),
        "order_accuracy_3_clauses": mean(order[3]),
        "order_accuracy_4_clauses": mean(order[4]),
        "prompts_3_clauses": len(order[3]),
        "prompts_4_clauses": len(order[4]),
        "transition_score_sim": mean([r["transition_score"] for r in ran if r["transition_score"] is not None]),
        "transition_score_blended": mean([r["transition_kinematic_blended"] for r in joined]),
        "transition_score_naive": mean([r["transition_kinematic_naive"] for r in joined if r["transition_kinematic_naive"] is not None]),
        "wall_seconds": round(wall_seconds, 1),
        "results": rows,
    }


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 5)
