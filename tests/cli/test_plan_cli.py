"""`g1ctl plan` and `g1ctl bench text` end to end, in a subprocess: decomposition, a simulated run, refusals."""

from __future__ import annotations

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


@pytest.mark.parametrize("prompt", ["do a backflip", "walk forward 500 meters"])
def test_requests_the_stack_cannot_do_are_refused_in_one_line(prompt: str) -> None:
    line = one_line_error(g1ctl("plan", prompt, "--sim"))
    assert "cannot plan" in line and "walk" in line  # names the part and what the stack can do


def test_video_needs_a_simulated_run() -> None:
    assert "--sim" in one_line_error(g1ctl("plan", "wave", "--video", "x.mp4"))


@pytest.mark.slow
def test_text_bench_runs_a_suite(tmp_path: Path) -> None:
    suite = tmp_path / "suite.yaml"
    suite.write_text(
        "prompts:\n"
        "  - text: turn right 90 degrees and then walk forward half a meter\n"
        "    expect: {clauses: 2, forward_m: 0.0, left_m: -0.5, heading_deg: -90}\n"
        "  - text: please juggle three balls\n"
        "    refuse: true\n"
    )
    report_path = tmp_path / "bench.json"
    result = g1ctl("bench", "text", "--suite", str(suite), "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["prompts"] == 2 and report["success_rate"] == 1.0, report["results"]
    ran = report["results"][0]
    assert ran["transition_kinematic_blended"] < ran["transition_kinematic_naive"]


def test_text_bench_names_a_bad_suite(tmp_path: Path) -> None:
    suite = tmp_path / "suite.yaml"
    suite.write_text("prompts:\n  - text: wave\n    expect: {gestures: [juggle]}\n")
    assert "juggle" in one_line_error(g1ctl("bench", "text", "--suite", str(suite)))
