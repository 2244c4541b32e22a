"""The estimate's judge: drift, heading drift, velocity error and waypoint errors, on states whose answers are known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.reference.waypoints import WaypointError
from controller.runtime.estimation import EstimateJudge
from hw import quat
from hw.types import RobotState


def _state(t: float, x: float, y: float, yaw: float, vx: float = 0.0, vy: float = 0.0) -> RobotState:
    return RobotState(
        time=t, joint_pos=np.zeros(29), joint_vel=np.zeros(29), base_quat=quat.from_yaw(yaw), base_ang_vel=np.zeros(3),
        base_pos=np.array([x, y, 0.79]), base_lin_vel=np.array([vx, vy, 0.0]),
    )  # fmt: skip


def test_a_perfect_estimate_has_no_drift_and_the_distance_is_the_truths_path() -> None:
    judge = EstimateJudge()
    for i in range(101):  # 1 m along x in 1 s, then 1 m along y
        t = i * 0.02
        x, y = min(t, 1.0), max(t - 1.0, 0.0)
        s = _state(t, x, y, 0.0, 1.0 if t < 1.0 else 0.0, 1.0 if t >= 1.0 else 0.0)
        judge.record(s, s, (True, False), (True, False))
    r = judge.report()
    assert r["distance_m"] == pytest.approx(2.0, abs=1e-9)
    assert r["position_drift_m"] == 0.0 and r["heading_drift_deg_per_min"] == 0.0 and r["velocity_rmse_mps"] == 0.0
    assert r["contact_decisions"] == 202 and r["contact_disagreements"] == 0


def test_drift_is_judged_in_the_frame_the_estimate_started_in() -> None:
    """The estimate starts at the origin facing 0; the truth started at (5, 5) facing 90 deg. Walking 1 m forward
    (truth: +y) the estimate says 0.98 m along x and a heading 1 deg off after 30 s: 2 cm drift, 2 deg/min."""
    judge = EstimateJudge()
    judge.record(_state(0.0, 0.0, 0.0, 0.0), _state(0.0, 5.0, 5.0, math.pi / 2), (True, True), (True, False))
    truth = _state(30.0, 5.0, 6.0, math.pi / 2, vx=0.0, vy=0.5)
    estimate = _state(30.0, 0.98, 0.0, math.radians(1.0), vx=0.5, vy=0.03)
    judge.record(estimate, truth, (True, True), (True, False))
    r = judge.report()
    assert r["distance_m"] == pytest.approx(1.0)
    assert r["position_drift_m"] == pytest.approx(0.02, abs=1e-4)
    assert r["drift_per_distance"] == pytest.approx(0.02, abs=1e-4)
    assert r["heading_drift_deg_per_min"] == pytest.approx(2.0, abs=1e-3)
    assert r["velocity_rmse_mps"] == pytest.approx(math.sqrt(0.03**2 / 2), abs=1e-4)  # the second sample's error only
    assert r["contact_disagreements"] == 2


def test_waypoint_errors_are_the_truths_at_the_settling_tick() -> None:
    judge = EstimateJudge()
    for i in range(10):
        s = _state(i * 0.1, 0.1 * i, 0.0, 0.0)
        truth = _state(i * 0.1, 0.1 * i + 0.05, 0.0, math.radians(3.0))
        judge.record(s, truth, (True, True), None)
    settled = [WaypointError(0.0, 0.0, 0.5, (0.5, 0.0, 0.0))]
    assert judge.waypoint_errors(settled) == [{"position_m": 0.05, "heading_deg": 3.0}]


def test_a_restart_aligns_the_frames_again() -> None:
    """The simulator stood the robot up at the origin after a fall and the estimate began afresh: no jump counts as drift."""
    judge = EstimateJudge()
    judge.record(_state(0.0, 0.0, 0.0, 0.0), _state(0.0, 0.0, 0.0, 0.0), (True, True), None)
    judge.record(_state(10.0, 2.0, 0.0, 0.0), _state(10.0, 2.1, 0.0, 0.0), (True, True), None)  # 0.1 m drift, then a fall
    judge.restart()
    judge.record(_state(10.02, 0.0, 0.0, 0.0), _state(10.02, 0.0, 0.0, 0.0), (True, True), None)
    judge.record(_state(20.0, 1.0, 0.0, 0.0), _state(20.0, 1.0, 0.0, 0.0), (True, True), None)
    r = judge.report()
    assert r["position_drift_m"] == 0.0 and r["distance_m"] == pytest.approx(1.0)
