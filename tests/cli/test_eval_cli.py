"""`g1ctl eval`: a sweep from the command line, its report, its overrides and its one-line refusals."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from controller.eval.runner import safety_failures
from controller.eval.stats import summarize
from tests.conftest import g1ctl, one_line_error

SUITE = """name: cli
duration_s: 2.0
policies: [fastsac]
perturbations:
  nominal: {}
seeds: 1
criteria:
  nominal: {min_survival: 1.0}
"""


def test_an_episode_damped_by_a_fault_did_not_survive() -> None:
    def episode(falls: int, ended_in_fault: bool) -> dict[str, object]:
        return {
            "group": "g",
            "condition": "c",
            "status": "done",
            "falls": falls,
            "velocity_error_mean": 0.1,
            "ended_in_fault": ended_in_fault,
        }

    figures = summarize([episode(0, False), episode(0, True), episode(1, False)])["g"]
    assert figures["survival"] == 0.3333 and figures["faults"] == 1 and figures["falls"] == 1
    lost = summarize([episode(0, False), {"group": "g", "condition": "c", "status": "failed", "error": "x"}])
    assert safety_failures(lost) == ["g: 1 episodes failed to run"]  # whatever the suite's criteria say


@pytest.mark.slow  # the CLI in a subprocess, episodes on the simulator and on simulated buses
def test_a_sweep_from_the_command_line_with_seeds_and_hardware_overridden(tmp_path: Path) -> None:
    suite = tmp_path / "cli.yaml"
    suite.write_text(SUITE)
    report_path = tmp_path / "cli.json"
    result = g1ctl("eval", "--suite", str(suite), "--seeds", "2", "--hardware", "sim-can", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]
    assert lines[0]["condition"] == "walk_turn_stop/fastsac/direct/sim-can/nominal" and lines[0]["episodes"] == 2
    assert lines[0]["survival"] == 1.0 and lines[0]["outside_limits"] == 0  # audited on the wire
    report = json.loads(report_path.read_text())
    assert [e["seed"] for e in report["episodes"]] == [0, 1] and report_path.with_suffix(".html").is_file()

    assert "is a real robot's config" in one_line_error(g1ctl("eval", "--suite", str(suite), "--hardware", "g1-dds"))
    assert "perturbations need the physics in this process" in one_line_error(g1ctl("eval", "--suite", str(suite), "--hardware", "sim-dds"))
    assert "seeds >= 1" in one_line_error(g1ctl("eval", "--suite", str(suite), "--seeds", "0"))
    assert "unknown suite 'nope'" in one_line_error(g1ctl("eval", "--suite", "nope"))
    names = g1ctl("scenarios").stdout  # where a user finds the names
    assert (
        "suites:        faults, robustness, smoke" in names
        and "overheat-left-knee" in names
        and "perturbations: low-friction, push, rough" in names
    )
