"""The state estimator in `g1ctl sim`: on the simulator with --estimator, and always through simulated buses."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import g1ctl, one_line_error


@pytest.mark.slow
def test_the_estimate_on_the_simulator_is_judged_by_its_truth(tmp_path: Path) -> None:
    report_path = tmp_path / "report.json"
    result = g1ctl("sim", "--scenario", "walk_turn_stop", "--duration", "6", "--estimator", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    block = report["estimator"]
    assert report["measured_by"] == "truth" and block["judged_by"] == "truth" and block["fault"] is None
    assert block["rate_hz"] == pytest.approx(50.0, rel=0.01) and block["updates"] >= 300
    assert block["distance_m"] > 1.5  # walking forward from 1 s on, and a turn
    assert block["drift_per_distance"] < 0.01 and block["velocity_rmse_mps"] < 0.05
    assert block["contact_disagreements"] < 0.05 * block["contact_decisions"]
    # the controller walked on the estimate; the run's figures are the truth's, the estimate's own beside them
    assert abs(block["controller_view"]["velocity_error_mean"] - report["velocity_error_mean"]) < 0.03


@pytest.mark.slow
def test_waypoints_through_simulated_buses_walk_on_the_estimate_and_reach_their_poses(tmp_path: Path) -> None:
    """Before the estimator this run aborted at 0.0 s: the buses measure no base position."""
    report_path = tmp_path / "report.json"
    result = g1ctl("sim", "--scenario", "waypoints", "--hardware", "sim-can", "--duration", "16", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["falls"] == 0 and report["final_mode"] == "run" and report["measured_by"] == "truth"
    assert report["waypoints_reached"] >= 2  # the square's first two corners in 16 s
    for error in report["waypoint_errors"]:  # judged by the simulator's truth
        assert error["position_m"] <= 0.10 and error["heading_deg"] <= 5.0
    assert len(report["estimator"]["controller_view"]["waypoint_errors"]) == report["waypoints_reached"]
    assert report["estimator"]["drift_per_distance"] < 0.01


def test_an_estimator_config_without_the_estimator_is_one_line() -> None:
    result = g1ctl("sim", "--duration", "1", "--estimator-config", "configs/estimator.yaml")
    assert result.returncode == 2
    assert "--estimator-config: the simulator measures the base position itself; add --estimator" in one_line_error(result)
