"""Suites cross into episodes; the report's figures; a sweep resumes; Ray gives the same results as this process."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from controller.eval.runner import EvalConfig, run_suite
from controller.eval.stats import largest_impulse_survived, wilson_interval
from controller.eval.suite import Criteria, SuiteConfig, episodes, load_suite
from hw.errors import ConfigError

SHOVE = {"pushes": {"force_n": 900.0, "start_s": 0.5}}  # 90 N s: the G1 goes down
TINY = SuiteConfig(
    name="tiny", duration_s=2.5, policies=("fastsac",), perturbations={"nominal": {}, "shoved": SHOVE}, seeds=1,
    criteria={"nominal": Criteria(min_survival=1.0), "shoved": Criteria(min_survival=1.0)},
)  # fmt: skip


def test_the_smoke_suite_crosses_into_twelve_episodes_with_stable_ids() -> None:
    every = episodes(load_suite("smoke"))
    assert len(every) == 12 and len({e.id for e in every}) == 12
    assert every[0].id == "random_commands/fastsac/direct/none/nominal/seed0"
    assert {e.condition for e in every} == {"nominal", "push"} and {e.seed for e in every} == {0, 1, 2}


def test_criteria_must_name_a_condition() -> None:
    with pytest.raises(ConfigError, match="criteria for unknown conditions: pushed"):
        episodes(SuiteConfig(name="x", duration_s=1.0, criteria={"pushed": Criteria()}))


def test_wilson_interval_and_the_largest_impulse_survived() -> None:
    low, high = wilson_interval(9, 10)
    assert (round(low, 4), round(high, 4)) == (0.5958, 0.9821)  # the textbook values for 9 of 10
    assert wilson_interval(0, 0) == (0.0, 1.0) and wilson_interval(5, 5)[1] == 1.0
    assert largest_impulse_survived([(10.0, 1.0), (20.0, 0.95), (30.0, 0.7), (40.0, 0.92)]) == 20.0
    assert largest_impulse_survived([(10.0, 0.5)]) is None


def test_a_sweep_reports_per_condition_resumes_and_names_a_missed_criterion(tmp_path: Path) -> None:
    report_path = tmp_path / "tiny.json"
    report = run_suite(EvalConfig(TINY, "tiny", report=report_path))
    conditions = report["conditions"]
    assert conditions["walk_turn_stop/fastsac/direct/none/nominal"]["survival"] == 1.0
    assert conditions["walk_turn_stop/fastsac/direct/none/shoved"]["falls"] >= 1  # 90 N s topples it
    assert report["criteria_failures"] == ["walk_turn_stop/fastsac/direct/none/shoved: survival 0.00 < 1.00"]
    assert [json.loads(line)["id"] for line in report_path.with_suffix(".jsonl").read_text().splitlines()] == [
        e["id"] for e in report["episodes"]
    ]
    again = run_suite(EvalConfig(TINY, "tiny", report=report_path))  # nothing left to do: the journal has both
    assert again["episodes_run"] == 0 and again["episodes"] == report["episodes"]


@pytest.mark.slow  # starts a local Ray instance
def test_ray_workers_give_the_same_results_as_this_process(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason="the eval extra (ray) is not installed")
    here = run_suite(EvalConfig(TINY, "tiny"))
    on_ray = run_suite(EvalConfig(TINY, "tiny", workers=2, report=tmp_path / "ray.json"))

    def results(report: dict[str, object]) -> list[dict[str, object]]:
        return [{k: v for k, v in e.items() if k != "episode_seconds"} for e in report["episodes"]]  # type: ignore[attr-defined]

    assert results(here) == results(on_ray) and on_ray["workers"] == 2


def test_push_curves_and_the_html_page(tmp_path: Path) -> None:
    from controller.eval.stats import push_curves

    def figures(condition: str, impulse: float, survival: float, pushes_only: bool = True) -> dict[str, object]:
        return {"condition": condition, "survival": survival, "push_impulse_ns": impulse, "pushes_only": pushes_only}

    conditions = {
        "walk/fastsac/direct/none/nominal": figures("nominal", 0.0, 1.0),
        "walk/fastsac/direct/none/push_10": figures("push_10", 10.0, 1.0),
        "walk/fastsac/direct/none/push_30": figures("push_30", 30.0, 0.5),
        "walk/fastsac/direct/none/slippery": figures("slippery", 0.0, 0.5, pushes_only=False),  # not on the curve
    }
    curve = push_curves(conditions)["walk/fastsac/direct/none"]  # type: ignore[arg-type]
    assert curve["impulse_ns"] == [0.0, 10.0, 30.0] and curve["impulse_survived_at_90_ns"] == 10.0
    report = run_suite(EvalConfig(TINY, "tiny", report=tmp_path / "tiny.json"))
    page = (tmp_path / "tiny.html").read_text()
    assert page.startswith("<!doctype html>") and page.count("data:image/png;base64,") == 2  # survival, and the push curve
    assert "survival 0.00 &lt; 1.00" in page and report["push_curves"]


def test_two_runs_disagree_only_outside_each_others_interval() -> None:
    from controller.eval.stats import disagreements

    def figures(survival: float, low: float, high: float) -> dict[str, object]:
        return {"survival": survival, "survival_ci95": [low, high]}

    first = {"a": figures(1.0, 0.51, 1.0), "b": figures(1.0, 0.51, 1.0), "c": figures(0.5, 0.15, 0.85)}
    second = {"a": figures(0.75, 0.3, 0.95), "b": figures(0.0, 0.0, 0.49), "c": figures(0.5, 0.15, 0.85)}
    assert [line.split(":")[0] for line in disagreements(first, second)] == ["b"]  # type: ignore[arg-type]
