"""Judging text plans: read as asked (the program against the expectation), done as asked (clause by clause), the order,
and the suites' shape."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from controller.bench.text import Expectation, SuitePrompt, load_suite, read_check
from controller.bench.text_judge import ClauseExpectation, Tolerances, in_expected_order, judge_clauses, read_as_expected
from controller.text.program import GESTURE_NAMES, Clause, Motion, Program, RelativeWaypoint
from hw.errors import ConfigError

PROMPTS = Path(__file__).resolve().parents[3] / "configs" / "prompts"
TOL = Tolerances(0.35, 20.0)
DETECTABLE = GESTURE_NAMES[:6]

PROGRAM = Program(
    "walk forward 1 m, then turn left while waving",
    (
        Clause("walk forward 1 m", Motion((RelativeWaypoint(1.0, 0.0, 0.0),))),
        Clause("turn left while waving", Motion((RelativeWaypoint(0.0, 0.0, 90.0),)), ("wave_right",), source=1),
    ),
)
EXPECTED = (ClauseExpectation(1.0, 0.0, 0.0), ClauseExpectation(0.0, 0.0, 90.0, ("wave_right",)))


def _measured(forward: float, left: float, heading: float, gestures: tuple[str, ...] = ()) -> dict[str, Any]:
    return {"displacement": [forward, left], "heading_change_deg": heading, "gestures": list(gestures), "timed_out": False}


def test_a_program_is_read_as_expected_or_the_first_difference_is_named() -> None:
    assert read_as_expected(PROGRAM, EXPECTED) == (True, "ok")
    ok, why = read_as_expected(PROGRAM, (EXPECTED[0], ClauseExpectation(0.0, 0.0, -90.0, ("wave_right",))))
    assert not ok and "clause 2" in why and "-90" in why
    ok, why = read_as_expected(PROGRAM, (EXPECTED[0], ClauseExpectation(0.0, 0.0, 90.0, ("wave_left",))))
    assert not ok and "wave_left" in why
    assert not read_as_expected(PROGRAM, EXPECTED[:1])[0]


def test_clauses_are_judged_each_in_their_own_frame_and_an_unasked_gesture_fails() -> None:
    good = [_measured(0.95, 0.05, 2.0), _measured(0.02, 0.0, 84.0, ("wave_right",))]
    assert judge_clauses(good, EXPECTED, TOL, DETECTABLE)[0]
    extra = [_measured(0.95, 0.05, 2.0, ("raise_left",)), good[1]]
    ok, why, verdicts = judge_clauses(extra, EXPECTED, TOL, DETECTABLE)
    assert not ok and "raise_left" in why and "not asked" in why and [v["pass"] for v in verdicts] == [False, True]
    short = [_measured(0.5, 0.0, 0.0), good[1]]
    assert "0.50 m from its goal" in judge_clauses(short, EXPECTED, TOL, DETECTABLE)[1]
    missing = [good[0], _measured(0.0, 0.0, 90.0)]
    assert "not seen" in judge_clauses(missing, EXPECTED, TOL, DETECTABLE)[1]


def test_order_is_against_the_expected_clauses() -> None:
    measured = [_measured(1.0, 0.0, 0.0), _measured(0.0, 0.0, 90.0, ("wave_right",))]
    assert in_expected_order(measured, EXPECTED, TOL, DETECTABLE)
    assert not in_expected_order(measured[::-1], EXPECTED, TOL, DETECTABLE)
    assert not in_expected_order(measured[:1], EXPECTED, TOL, DETECTABLE)


@pytest.mark.parametrize("name", ["suite.yaml", "heldout.yaml", "heldout-dev.yaml"])
def test_the_shipped_suites_load(name: str) -> None:
    suite = load_suite(PROMPTS / name)
    assert len(suite.prompts) >= 59
    for prompt in suite.prompts:
        if prompt.clauses:
            assert 1 <= len(prompt.clauses) <= 12


def test_a_held_out_suite_has_what_the_issue_asks_for() -> None:
    prompts = load_suite(PROMPTS / "heldout.yaml").prompts
    assert len(prompts) >= 60
    assert sum(p.refuse for p in prompts) >= 20 and sum(p.carry_or_refuse for p in prompts) >= 5
    assert sum(len(p.clauses) in (3, 4) for p in prompts) >= 15
    assert {"perception", "curve", "tracks", "hold"} <= {t for p in prompts for t in p.tags}


def test_a_suite_prompt_says_one_thing(tmp_path: Path) -> None:
    path = tmp_path / "suite.yaml"
    path.write_text("prompts:\n  - text: wave\n    refuse: true\n    clauses: [{gestures: [wave_right]}]\n")
    with pytest.raises(ConfigError, match="exactly one of refuse, expect or clauses"):
        load_suite(path)
    path.write_text("prompts:\n  - text: wave\n    clauses: [{gestures: [juggle]}]\n")
    with pytest.raises(ConfigError, match="juggle"):
        load_suite(path)


def test_the_projects_suite_is_read_by_its_totals() -> None:
    asked = SuitePrompt("...", expect=Expectation(clauses=2, forward_m=1.0, heading_deg=90.0, gestures=("wave_right",)))
    assert read_check(asked, PROGRAM) == (True, "ok")
    turned_right = SuitePrompt("...", expect=Expectation(clauses=2, forward_m=1.0, heading_deg=-90.0))
    assert not read_check(turned_right, PROGRAM)[0]
    three = SuitePrompt("...", expect=Expectation(clauses=3, forward_m=1.0, heading_deg=90.0))
    assert "3" in read_check(three, PROGRAM)[1]
