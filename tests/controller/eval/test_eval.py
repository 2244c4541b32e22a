"""Suites cross into episodes; the report's figures; a sweep resumes; Ray gives the same results as this process."""

from __future__ import annotations

import dataclasses
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
    assert again["episodes_resumed"] == 2 and again["wall_seconds"] >= report["wall_seconds"]  # the first call's time is kept


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

    first = {"a": figures(1.0, 0.51, 1.0), "b": figures(1.0, 0.51, 1.0), "c": figures(0.5, 0.15, 0.85), "d": figures(0.75, 0.3, 0.95)}
    second = {"a": figures(0.75, 0.3, 0.95), "b": figures(0.0, 0.0, 0.49), "c": figures(0.5, 0.15, 0.85), "d": figures(1.0, 0.51, 1.0)}
    # One fall against none, either way round, is within reach; all against none is not.
    assert [line.split(":")[0] for line in disagreements(first, second)] == ["b"]  # type: ignore[arg-type]


def test_the_faults_suite_drills_every_shipped_plan_on_the_hardware_it_names() -> None:
    from hw.emulation.faults import available_fault_plans

    every = episodes(load_suite("faults"))
    plans = available_fault_plans()
    assert len(plans) >= 16 and len(every) == 2 * len(plans)  # with and without the planner
    assert sorted(e.condition for e in every if not e.planner) == plans == sorted(e.condition for e in every if e.planner)
    hardware = {e.condition: e.hardware for e in every}
    assert hardware["overheat-left-knee"] == "sim-can" and hardware["rs485-crc"] == "sim-mixed" and hardware["dds-stale"] == "sim-dds"
    assert all(e.faults is not None and e.id.endswith(f"/{e.condition}/seed0") for e in every)
    with pytest.raises(ConfigError, match="lossy-can is both a perturbation label and a fault plan"):
        episodes(SuiteConfig(name="x", duration_s=1.0, perturbations={"lossy-can": {}}, faults=("lossy-can",)))
    with pytest.raises(ConfigError, match="the suite has no episodes"):
        episodes(SuiteConfig(name="x", duration_s=1.0, perturbations={}))


@pytest.mark.slow
def test_drills_pass_and_a_drill_that_misses_its_stated_time_is_named(tmp_path: Path) -> None:
    impatient = tmp_path / "impatient-imu.yaml"  # the IMU times out after 50 ms: 10 ms cannot be met
    impatient.write_text("buses:\n  imu: {silent: true, start_s: 3.0}\nexpect: {outcome: damping, within_s: 0.01, names: IMU}\n")
    suite = SuiteConfig(
        name="drills", duration_s=3.5, perturbations={}, faults=("overheat-left-knee", "wild-command", str(impatient)), seeds=1
    )
    report = run_suite(EvalConfig(suite, "drills", report=tmp_path / "drills.json"))
    assert "<h2>Fault drills</h2>" in (tmp_path / "drills.html").read_text()
    conditions = report["conditions"]
    knee = conditions["walk_turn_stop/fastsac/direct/sim-can/overheat-left-knee"]
    assert knee["drills_passed"] == 1 and knee["damping_latency_max_s"] <= 0.02 and knee["outside_limits"] == 0
    assert conditions["walk_turn_stop/fastsac/direct/sim-can/wild-command"]["drills_passed"] == 1
    (failure,) = report["criteria_failures"]
    assert failure.startswith("walk_turn_stop/fastsac/direct/sim-can/impatient-imu: drill failed: seed 0: every motor safe")
    assert "more than the 10 ms stated" in failure


def test_an_episode_with_its_robot_in_another_process_holds_two_cpus() -> None:
    from controller.eval.runner import episode_cpus

    assert (episode_cpus("none"), episode_cpus("sim-can"), episode_cpus("sim-dds")) == (1, 1, 2)


def test_trackers_cross_with_the_planner_and_plan_followers_run_only_with_it(assets) -> None:
    from controller.tracking.registry import PLAN_FOLLOWING, TrackerSpec, available_trackers, make_tracker
    from hw import g1

    for name in available_trackers():  # the registry's list agrees with the trackers themselves
        assert make_tracker(name, TrackerSpec("fastsac", assets, g1.JOINT_NAMES)).needs_plan == (name in PLAN_FOLLOWING), name
    suite = SuiteConfig(name="t", duration_s=2.5, planner=(False, True), trackers=("default", "whole-body"), seeds=1)
    groups = [e.group for e in episodes(suite)]
    assert groups == [
        "walk_turn_stop/fastsac/direct/none/nominal",
        "walk_turn_stop/fastsac/planner/none/nominal",
        "walk_turn_stop/fastsac/planner+whole-body/none/nominal",
    ]
    report = run_suite(EvalConfig(dataclasses.replace(suite, planner=(True,), trackers=("whole-body",)), "t"))
    (episode,) = report["episodes"]
    assert episode["status"] == "done" and episode["falls"] == 0, episode
    with pytest.raises(ConfigError, match="unknown trackers"):
        SuiteConfig(name="t", duration_s=1.0, trackers=("nope",))
    with pytest.raises(ConfigError, match=r"follow planned motion: add planner: \[true\]"):
        SuiteConfig(name="t", duration_s=1.0, trackers=("whole-body",))
