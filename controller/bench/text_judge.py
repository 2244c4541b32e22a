"""Judging a text plan against what a person expects of the prompt: read as asked, then done as asked, clause by clause.

Two questions, kept apart:
- **Read as asked** (`read_as_expected`): the resolved program itself, before anything
  moves, against the expected clauses (their number, each clause's goal displacement, turn
  and gestures). A program that does not match was about to run something other than what
  was asked: the failure the planner must never make, counted on its own
  (`ran_as_something_else`), apart from a motion that fell short.
- **Done as asked** (`judge_clauses`): what each executed clause measurably did
  (displacement in its start frame, heading change, the gestures the detector saw in the
  arm motion) against the same expectation, within the suite's tolerances. A gesture seen
  that was not asked for fails the clause, as a missing one does.

Order (`in_expected_order`): each executed clause is matched to the nearest expected clause
(displacement and heading in units of the tolerances, a gesture mismatch counting one);
the prompt is in order when clause i matches expected clause i for every i. The expectation
is a person's reading of the prompt's words, so this is order against the words, not
against the planner's own reading of them. Pure functions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from controller.text.program import Program
from controller.text.resolve import end_pose

# The program's goal is exact; the expectation was worked out by hand. Goals within these are read as expected.
READ_POSITION_M = 0.1
READ_HEADING_DEG = 3.0


@dataclass(frozen=True)
class ClauseExpectation:
    """One clause as a person reads the prompt: its displacement in its own start frame, its turn, the gestures seen in it."""

    forward_m: float = 0.0
    left_m: float = 0.0
    heading_deg: float = 0.0
    gestures: tuple[str, ...] = ()


@dataclass(frozen=True)
class Tolerances:
    position_m: float
    heading_deg: float


def read_as_expected(program: Program, expected: Sequence[ClauseExpectation]) -> tuple[bool, str]:
    """Does the resolved program do, clause by clause, what the expectation says? (and if not, the first difference)."""
    if len(program.clauses) != len(expected):
        return False, f"read as {len(program.clauses)} clauses, expected {len(expected)}"
    for i, (clause, e) in enumerate(zip(program.clauses, expected, strict=True), 1):
        f, lt, h = clause.displacement
        if math.hypot(f - e.forward_m, lt - e.left_m) > READ_POSITION_M:
            return False, f"clause {i} read as ({f:.2f}, {lt:.2f}) m, expected ({e.forward_m}, {e.left_m})"
        if abs(h - e.heading_deg) > READ_HEADING_DEG:
            return False, f"clause {i} read as a turn of {h:.0f} degrees, expected {e.heading_deg:.0f}"
        if set(clause.gestures) != set(e.gestures):
            return False, f"clause {i} read with gestures {sorted(clause.gestures)}, expected {sorted(e.gestures)}"
    return True, "ok"


def read_totals_as_expected(
    program: Program, clauses: int | None, forward_m: float, left_m: float, heading_deg: float, gestures: Sequence[str]
) -> tuple[bool, str]:
    """The project's suite, which states totals: the typed clause count, where the program ends, its gestures."""
    if clauses is not None and program.typed_clauses != clauses:
        return False, f"read as {program.typed_clauses} clauses, expected {clauses}"
    f, lt, h = end_pose(program.clauses)
    if math.hypot(f - forward_m, lt - left_m) > READ_POSITION_M or abs(h - heading_deg) > READ_HEADING_DEG:
        return False, f"read as ending at ({f:.2f}, {lt:.2f}) m, {h:.0f} degrees; expected ({forward_m}, {left_m}), {heading_deg:.0f}"
    missing = set(gestures) - {g for c in program.clauses for g in c.gestures}
    if missing:
        return False, f"read without the gestures {sorted(missing)}"
    return True, "ok"


def judge_clauses(
    measured: Sequence[dict[str, Any]], expected: Sequence[ClauseExpectation], tol: Tolerances, detectable: Sequence[str]
) -> tuple[bool, str, list[dict[str, Any]]]:
    """Pass or fail of the executed clauses (the text report's `clauses`), the first reason, and a verdict per clause.

    Gestures are judged on the names the detector knows (`detectable`): every expected one must
    be seen in its clause, and none that was not asked for.
    """
    verdicts = []
    first = "ok"
    if len(measured) != len(expected):
        first = f"{len(measured)} clauses ran, expected {len(expected)}"
    for i, (m, e) in enumerate(zip(measured, expected, strict=False), 1):
        problems = []  # a clause that timed out is judged on where it got to, like any other (its timeout is reported)
        if m["displacement"] is not None:
            miss = math.hypot(m["displacement"][0] - e.forward_m, m["displacement"][1] - e.left_m)
            if miss > tol.position_m:
                problems.append(f"ended {miss:.2f} m from its goal")
        if abs(m["heading_change_deg"] - e.heading_deg) > tol.heading_deg:
            problems.append(f"turned {m['heading_change_deg']:.0f} degrees, expected {e.heading_deg:.0f}")
        seen = set(m["gestures"]) & set(detectable)
        asked = set(e.gestures) & set(detectable)
        if asked - seen:
            problems.append(f"gestures {sorted(asked - seen)} not seen")
        if seen - asked:
            problems.append(f"gestures {sorted(seen - asked)} seen but not asked for")
        verdicts.append({"clause": i, "pass": not problems, "problems": problems})
        if problems and first == "ok":
            first = f"clause {i}: {'; '.join(problems)}"
    return first == "ok", first, verdicts


def in_expected_order(
    measured: Sequence[dict[str, Any]], expected: Sequence[ClauseExpectation], tol: Tolerances, detectable: Sequence[str]
) -> bool:
    """Each executed clause is nearest to the expected clause of its own index (and all ran)."""
    if len(measured) != len(expected):
        return False
    for i, m in enumerate(measured):
        costs = [_distance(m, e, tol, set(detectable)) for e in expected]
        best = min(range(len(costs)), key=lambda k: (costs[k], k != i))
        if best != i:
            return False
    return True


def _distance(m: dict[str, Any], e: ClauseExpectation, tol: Tolerances, detectable: set[str]) -> float:
    f, lt = m["displacement"] or (0.0, 0.0)
    cost = math.hypot(f - e.forward_m, lt - e.left_m) / tol.position_m + abs(m["heading_change_deg"] - e.heading_deg) / tol.heading_deg
    return cost + (0.0 if set(m["gestures"]) & detectable == set(e.gestures) & detectable else 1.0)
