"""`g1ctl plan` and `g1ctl bench text` end to end, in a subprocess: decomposition, a simulated run, a run through simulated
buses, refusals."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from tests.conftest import g1ctl, one_line_error


def test_plan_prints_the_decomposition_without_running() -> None:
    result = g1ctl("plan", "Please walk forward two meters, then turn left 90 degrees, then wave with your right hand")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.strip().splitlines()
    assert len(lines) >= 3
    assert "wave_right" in result.stdout and "90" in result.stdout


@pytest.mark.slow
def test_plan_runs_in_simulation_and_reports_each_clause(tmp_path: Path) -> None:
    report_path = tmp_path / "plan.json"
    result = g1ctl("plan", "walk forward one meter and then wave with your left hand", "--sim", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["falls"] == 0 and len(report["clauses"]) == 2
    walk, wave = report["clauses"]
    assert walk["displacement"][0] == pytest.approx(1.0, abs=0.2) and abs(walk["heading_change_deg"]) < 15
    assert "wave_left" in wave["gestures"] and wave["start_s"] == walk["end_s"]
    assert report["total_displacement"][0] == pytest.approx(1.0, abs=0.25)
    assert report["order_accuracy"] == 1.0 and report["transition_score"] is not None
    assert {"text", "start_s", "end_s", "displacement", "heading_change_deg", "gestures"} <= set(walk)
    # On the simulator directly the controller's view is the truth itself: the two sets of figures agree exactly.
    assert report["measured_by"] == "truth"
    for clause in report["clauses"]:
        assert clause["displacement_estimate"] == clause["displacement"]
        assert clause["heading_change_deg_estimate"] == clause["heading_change_deg"]
    assert report["total_displacement_estimate"] == report["total_displacement"]
    assert report["total_heading_change_deg_estimate"] == report["total_heading_change_deg"]


@pytest.mark.slow
def test_plan_runs_through_simulated_buses_judged_by_the_truth(tmp_path: Path) -> None:
    """A prompt that stays put runs on any hardware: the truth judges it, the controller's view stands beside it."""
    report_path = tmp_path / "plan.json"
    result = g1ctl("plan", "wave with your right hand", "--hardware", "sim-can", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["falls"] == 0 and report["measured_by"] == "truth" and report["run"]["hw"]["faults"] == 0
    (wave,) = report["clauses"]
    assert wave["gestures"] == ["wave_right"] and not wave["timed_out"] and report["order_accuracy"] == 1.0
    assert abs(wave["displacement"][0]) < 0.1 and abs(wave["displacement"][1]) < 0.1
    if wave["displacement_estimate"] is not None:  # a state estimator stands behind the controller's view
        assert wave["displacement_estimate"] == pytest.approx(wave["displacement"], abs=0.05)
    assert wave["heading_change_deg_estimate"] == pytest.approx(wave["heading_change_deg"], abs=2.0)  # the IMU's heading


@pytest.mark.slow
def test_a_plan_that_walks_on_hardware_needs_a_base_position(tmp_path: Path) -> None:
    """Where the controller's state has no base position the walk is refused at its start, in one line; where an estimator
    gives one it runs, judged by the truth."""
    report_path = tmp_path / "plan.json"
    result = g1ctl("plan", "walk forward half a meter", "--hardware", "sim-can", "--report", str(report_path))
    if result.returncode != 0:
        line = one_line_error(result, code=1)
        assert line.startswith("g1ctl: fault: run aborted after 0.0 s: the text plan moves the base ('walk forward 0.5 meter')")
        assert "no base position estimate" in line and "--sim" in line
        return
    report = json.loads(report_path.read_text())
    assert report["measured_by"] == "truth" and report["total_displacement"][0] == pytest.approx(0.5, abs=0.15)
    assert report["total_displacement_estimate"] is not None


@pytest.mark.parametrize(
    "prompt", ["do a backflip", "walk forward 500 meters", "", "walk " * 120, "\x01\x02", "walk until you see the door", "and then"]
)
def test_requests_the_stack_cannot_do_are_refused_in_one_line(prompt: str) -> None:
    line = one_line_error(g1ctl("plan", prompt, "--sim"), code=1)
    assert line.startswith("g1ctl: refused: cannot plan") and "walk" in line  # names the part and what the stack can do


def test_video_needs_a_simulated_run() -> None:
    assert "--sim" in one_line_error(g1ctl("plan", "wave", "--video", "x.mp4"))


def test_sim_and_hardware_are_two_ways_to_run_choose_one() -> None:
    line = one_line_error(g1ctl("plan", "wave", "--sim", "--hardware", "sim-can"))
    assert "--sim and --hardware" in line and "choose one" in line


def test_an_unknown_hardware_is_named_with_the_valid_ones() -> None:
    line = one_line_error(g1ctl("plan", "wave", "--hardware", "sim-cna"))
    assert "'sim-cna'" in line and "sim-can" in line


@pytest.mark.skipif(importlib.util.find_spec("cyclonedds") is None, reason="the g1 extra (cyclonedds) is not installed")
@pytest.mark.parametrize(("option", "value"), [("--video", "x.mp4"), ("--progress", None)])
def test_a_real_robot_refuses_what_needs_the_simulator(option: str, value: str | None) -> None:
    line = one_line_error(g1ctl("plan", "wave", "--hardware", "g1-dds", option, *([value] if value else [])))
    assert line.startswith(f"g1ctl: error: {option}: not on a real robot")


@pytest.mark.slow
def test_text_bench_runs_a_suite(tmp_path: Path) -> None:
    suite = tmp_path / "suite.yaml"
    suite.write_text(
        "prompts:\n"
        "  - text: turn right 90 degrees and then walk forward half a meter\n"
        "    expect: {clauses: 2, forward_m: 0.0, left_m: -0.5, heading_deg: -90}\n"
        "  - text: walk forward half a meter while waving with your left hand, then turn left\n"
        "    tags: [tracks]\n"
        "    clauses:\n"
        "      - {forward_m: 0.5, gestures: [wave_left]}\n"
        "      - {heading_deg: 90}\n"
        "  - text: walk forward half a meter, then turn right\n"
        "    carry_or_refuse: true\n"
        "    clauses: [{forward_m: 0.5}, {heading_deg: 90}]\n"
        "  - text: please juggle three balls\n"
        "    refuse: true\n"
    )
    report_path = tmp_path / "bench.json"
    result = g1ctl("bench", "text", "--suite", str(suite), "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["prompts"] == 4 and report["passed"] == 3, report["results"]
    first, tracks, misread, _ = report["results"]
    assert first["pass"] and first["transition_kinematic_blended"] < first["transition_kinematic_naive"]
    assert first["transition_kinematic_crossfade"] is not None
    assert tracks["pass"] and [v["pass"] for v in tracks["clause_verdicts"]] == [True, True]
    # turning right where the suite says left: read as something else, and not run
    assert misread["misread"] and "read as something else" in misread["reason"] and "falls" not in misread
    assert report["ran_as_something_else"] == 1 and report["clauses_decided_by_encoder"] == 0
    assert report["pass_rate_by_tag"] == {"tracks": 1.0}


def test_text_bench_names_a_bad_suite(tmp_path: Path) -> None:
    suite = tmp_path / "suite.yaml"
    suite.write_text("prompts:\n  - text: wave\n    expect: {gestures: [juggle]}\n")
    assert "juggle" in one_line_error(g1ctl("bench", "text", "--suite", str(suite)))
