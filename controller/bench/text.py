"""`g1ctl bench text`: a suite of typed prompts, each read, run on the simulated G1 and passed or failed with its reason.

Suites (`configs/prompts/suite.yaml` by default; `--suite PATH`, e.g. the held-out
`configs/prompts/heldout.yaml`) state for each prompt either that it must be refused
(`refuse`), what the whole prompt does (`expect`: the typed clause count, the total
displacement and turn, the gestures seen somewhere: the project's suite), or what each
clause does (`clauses`: displacement in the clause's start frame, turn, gestures: the
held-out suites). `carry_or_refuse` prompts, written to tempt a parser into misreading,
pass refused or carried out as expected, never run as something else.

Per prompt: resolve it (`PromptRefused`: a refusal); check the program against the
expectation before anything moves (`text_judge.read_as_expected`: a mismatch is a prompt
that would have run as something other than what was asked, and is not run); run it in
simulation (the planner in the loop, blended joins) and judge what it did, clause by
clause where the suite says (`text_judge.judge_clauses`, unasked gestures failing). Then the
program runs kinematically (an ideal robot whose root moves as commanded, no physics) with
blended joins, with the crossfade baseline of the same length (the next clause planned from
a standing pose and crossfaded over the same frames) and with naive concatenation, so that
their `transition_score`s compare the composition alone.

Reported: per prompt pass/fail with the reason and the figures; the success rate; prompts run
as something else; prompts refused that should have run; order accuracy of the prompts of 3
and of 4 clauses; pass rates per tag; the share of parts decided by the lexicon and by the
encoder; the transition scores.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from controller.bench.text_judge import (
    ClauseExpectation,
    Tolerances,
    in_expected_order,
    judge_clauses,
    read_as_expected,
    read_totals_as_expected,
)
from controller.text.executor import TextRunConfig
from controller.text.program import GESTURE_NAMES, Program, PromptRefused
from hw import g1
from hw.errors import ConfigError
from hw.shipped import config_dir
from hw.types import FloatArray
from hw.yamlconfig import from_dict, load_yaml


@dataclass(frozen=True)
class Expectation:
    clauses: int | None = None
    forward_m: float = 0.0
    left_m: float = 0.0
    heading_deg: float = 0.0
    gestures: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        _check_gestures(self.gestures)


@dataclass(frozen=True)
class SuitePrompt:
    text: str
    expect: Expectation | None = None  # the whole prompt (the project's suite)
    clauses: tuple[ClauseExpectation, ...] = ()  # each clause (the held-out suites)
    refuse: bool = False
    carry_or_refuse: bool = False  # refused, or carried out as expected: never run as something else
    tags: tuple[str, ...] = ()
    position_tolerance_m: float | None = None
    heading_tolerance_deg: float | None = None

    def __post_init__(self) -> None:
        stated = sum((self.refuse, self.expect is not None, bool(self.clauses)))
        if stated != 1 or (self.carry_or_refuse and not self.clauses and self.expect is None):
            raise ConfigError(f'prompt "{self.text}": give exactly one of refuse, expect or clauses (carry_or_refuse needs one)')
        for c in self.clauses:
            _check_gestures(c.gestures)


def _check_gestures(names: tuple[str, ...]) -> None:
    unknown = [g for g in names if g not in GESTURE_NAMES]
    if unknown:
        raise ConfigError(f"expected gestures {unknown} are not gestures it plans; use {', '.join(GESTURE_NAMES)}")


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


def tolerances(prompt: SuitePrompt, defaults: SuiteDefaults) -> Tolerances:
    return Tolerances(
        prompt.position_tolerance_m or defaults.position_tolerance_m, prompt.heading_tolerance_deg or defaults.heading_tolerance_deg
    )


def read_check(prompt: SuitePrompt, program: Program) -> tuple[bool, str]:
    """Was the prompt read as the suite expects, before anything moves?"""
    if prompt.clauses:
        return read_as_expected(program, prompt.clauses)
    e = prompt.expect or Expectation()
    return read_totals_as_expected(program, e.clauses, e.forward_m, e.left_m, e.heading_deg, e.gestures)


def judge(prompt: SuitePrompt, defaults: SuiteDefaults, result: dict[str, Any]) -> tuple[bool, str, list[dict[str, Any]]]:
    """Pass or fail of one executed prompt, why, and the verdict per clause (per-clause suites)."""
    if result["falls"]:
        return False, f"fell {result['falls']} time(s)", []
    done = len(result["clauses"])
    if done != result["clauses_planned"]:
        return False, f"only {done} of {result['clauses_planned']} clauses ran", []
    tol = tolerances(prompt, defaults)
    if prompt.clauses:
        return judge_clauses(result["clauses"], prompt.clauses, tol, GESTURE_NAMES)
    e = prompt.expect or Expectation()
    forward, left = result["total_displacement"]
    miss = math.hypot(forward - e.forward_m, left - e.left_m)
    if miss > tol.position_m:
        return False, f"ended {miss:.2f} m from the expected place ({forward:.2f}, {left:.2f} against {e.forward_m}, {e.left_m})", []
    if abs(result["total_heading_change_deg"] - e.heading_deg) > tol.heading_deg:
        return False, f"turned {result['total_heading_change_deg']:.0f} degrees, expected {e.heading_deg:.0f}", []
    seen = {g for c in result["clauses"] for g in c["gestures"]}
    missing = [g for g in e.gestures if g in GESTURE_NAMES and g not in seen]
    if missing:
        return False, f"gestures {missing} not seen in the arm motion (seen: {sorted(seen) or 'none'})", []
    unasked = sorted(seen - set(e.gestures))
    if unasked:
        return False, f"gestures {unasked} seen but not asked for", []
    return True, "ok", []


@dataclass(frozen=True)
class TextBenchConfig:
    suite: Path | None = None
    seed: int = 0
    policy: str = "fastsac"
    limit: int | None = None  # only the first N prompts (a quick look)
    kinematic: bool = True  # also compare blended joins with the crossfade and naive baselines on the composed plan alone
    text_slot: bool = False  # also measure how much the clause text in the planner's text slot changes the composed plan


BLEND_FRAMES = TextRunConfig().blend_frames


def run_text_bench(
    cfg: TextBenchConfig,
    resolve: Callable[[str], Program],
    simulate: Callable[[Program], dict[str, Any]],
    compose: Callable[[Program, int | None, bool], float | None],
    progress: Callable[[str], None] = lambda line: None,
    frames: Callable[[Program, int, bool], FloatArray] | None = None,
) -> dict[str, Any]:
    """Run the suite: `resolve` (text -> program or PromptRefused), `simulate` (program -> text report), `compose` (program,
    blend frames or None, continue the motion -> kinematic transition score), `frames` (program, seed, with text -> the
    composed reference frames, for `text_slot`)."""
    suite = load_suite(cfg.suite)
    prompts = suite.prompts[: cfg.limit] if cfg.limit else suite.prompts
    rows = []
    started = time.perf_counter()
    for prompt in prompts:
        row = _run_prompt(prompt, suite.defaults, cfg, resolve, simulate, compose)
        if cfg.text_slot and frames is not None and "clauses" in row:
            row |= text_slot_effect(resolve(prompt.text), cfg.seed, frames)
        rows.append(row)
        progress(f"{'PASS' if row['pass'] else 'FAIL'} {prompt.text!r}: {row['reason']}")
    return summarize(rows, time.perf_counter() - started)


def _run_prompt(
    prompt: SuitePrompt,
    defaults: SuiteDefaults,
    cfg: TextBenchConfig,
    resolve: Callable[[str], Program],
    simulate: Callable[[Program], dict[str, Any]],
    compose: Callable[[Program, int | None, bool], float | None],
) -> dict[str, Any]:
    row: dict[str, Any] = {
        "text": prompt.text,
        "refuse": prompt.refuse,
        "carry_or_refuse": prompt.carry_or_refuse,
        "tags": list(prompt.tags),
    }
    try:
        program = resolve(prompt.text)
    except PromptRefused as exc:
        ok = prompt.refuse or prompt.carry_or_refuse
        hint = "closest to" in str(exc)  # the encoder named what the words are nearest to
        return row | {
            "pass": ok,
            "refused": True,
            "encoder_hint": hint,
            "reason": f"refused: {exc}" if ok else f"refused, but should run: {exc}",
        }
    row |= {"refused": False, "parts": len(program.clauses), "typed_clauses": program.typed_clauses}
    if prompt.refuse:
        return row | {"pass": False, "misread": True, "reason": f"planned {len(program.clauses)} clause(s), but should be refused"}
    read_ok, why = read_check(prompt, program)
    if not read_ok:
        return row | {"pass": False, "misread": True, "reason": f"read as something else: {why}"}
    result = simulate(program)
    passed, reason, verdicts = judge(prompt, defaults, result)
    expected = prompt.clauses
    order = (
        in_expected_order(result["clauses"], expected, tolerances(prompt, defaults), GESTURE_NAMES)
        if expected
        else result["order_accuracy"] == 1.0
    )
    row |= {
        "pass": passed,
        "misread": False,
        "reason": reason,
        "clauses": len(expected) if expected else program.typed_clauses,  # as the suite counts them (typed, or expected)
        "clause_verdicts": verdicts,
        "falls": result["falls"],
        "total_displacement": result["total_displacement"],
        "total_heading_change_deg": result["total_heading_change_deg"],
        "gestures": [c["gestures"] for c in result["clauses"]],
        "order_accuracy": 1.0 if order else 0.0,
        "transition_score": result["transition_score"],
        "run_seconds": result["run"]["run_seconds"],
        "timed_out_clauses": sum(c["timed_out"] for c in result["clauses"]),
    }
    if cfg.kinematic and len(program.clauses) > 1:
        row["transition_kinematic_blended"] = _rounded(compose(program, BLEND_FRAMES, True))
        row["transition_kinematic_crossfade"] = _rounded(compose(program, BLEND_FRAMES, False))
        row["transition_kinematic_naive"] = _rounded(compose(program, None, True))
    return row


def text_slot_effect(program: Program, seed: int, frames: Callable[[Program, int, bool], FloatArray]) -> dict[str, float]:
    """How far the clause text moves the composed plan (mean absolute joint change, rad; mean root distance, m), against
    how far another seed moves it without text: the text slot is useful only where the first clearly exceeds the second."""
    with_text, without, other_seed = frames(program, seed, True), frames(program, seed, False), frames(program, seed + 1, False)

    def apart(a: FloatArray, b: FloatArray) -> tuple[float, float]:
        n = min(len(a), len(b))
        joints = float(np.mean(np.abs(a[:n, g1.QPOS_JOINTS] - b[:n, g1.QPOS_JOINTS])))
        root = float(np.mean(np.linalg.norm(a[:n, :2] - b[:n, :2], axis=1)))
        return joints, root

    text_joints, text_root = apart(with_text, without)
    seed_joints, seed_root = apart(other_seed, without)
    return {
        "text_slot_joint_change_rad": round(text_joints, 5),
        "text_slot_root_change_m": round(text_root, 4),
        "seed_joint_change_rad": round(seed_joints, 5),
        "seed_root_change_m": round(seed_root, 4),
    }


def summarize(rows: list[dict[str, Any]], wall_seconds: float) -> dict[str, Any]:
    """The suite's figures from its rows."""

    def mean(values: list[float]) -> float | None:
        return round(float(np.mean(values)), 4) if values else None

    ran = [r for r in rows if "clauses" in r]
    order = {n: [r["order_accuracy"] for r in ran if r["clauses"] == n] for n in (3, 4)}
    joined = [r for r in ran if r.get("transition_kinematic_blended") is not None]
    tags = sorted({t for r in rows for t in r["tags"]})
    parts = sum(r.get("parts", 0) for r in rows)
    return {
        "prompts": len(rows),
        "passed": sum(r["pass"] for r in rows),
        "success_rate": round(sum(r["pass"] for r in rows) / len(rows), 4) if rows else None,
        "ran_as_something_else": sum(bool(r.get("misread")) for r in rows),
        "refused_but_should_run": sum(r["refused"] and not (r["refuse"] or r["carry_or_refuse"]) for r in rows),
        "refusals_expected": sum(r["refuse"] for r in rows),
        "falls": sum(r.get("falls", 0) for r in rows),
        "timed_out_clauses": sum(r.get("timed_out_clauses", 0) for r in rows),
        "order_accuracy_3_clauses": mean(order[3]),
        "order_accuracy_4_clauses": mean(order[4]),
        "prompts_3_clauses": len(order[3]),
        "prompts_4_clauses": len(order[4]),
        "pass_rate_by_tag": {t: round(float(np.mean([r["pass"] for r in rows if t in r["tags"]])), 4) for t in tags},
        # Every clause that runs is read by the lexicon and its handlers; the encoder only explains refusals (resolve.py).
        "clauses_decided_by_lexicon": parts,
        "clauses_decided_by_encoder": 0,
        "refusals_explained_by_encoder": sum(bool(r.get("encoder_hint")) for r in rows),
        "transition_score_sim": mean([r["transition_score"] for r in ran if r["transition_score"] is not None]),
        "transition_score_blended": mean([r["transition_kinematic_blended"] for r in joined]),
        "transition_score_crossfade": mean(
            [r["transition_kinematic_crossfade"] for r in joined if r["transition_kinematic_crossfade"] is not None]
        ),
        "transition_score_naive": mean([r["transition_kinematic_naive"] for r in joined if r["transition_kinematic_naive"] is not None]),
        "text_slot": {
            k: mean([r[k] for r in rows if k in r])
            for k in ("text_slot_joint_change_rad", "text_slot_root_change_m", "seed_joint_change_rad", "seed_root_change_m")
        },
        "wall_seconds": round(wall_seconds, 1),
        "results": rows,
    }


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 5)
