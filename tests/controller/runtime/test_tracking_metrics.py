"""Command response and plan-tracking metrics on synthetic series with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.reference.buffer import ReferenceSample
from controller.runtime.tracking_metrics import PlanTrackingMetrics, command_response_s
from hw import g1, quat
from hw.types import RobotState


def first_order(
    tau: float, dt: float = 0.02, seconds: float = 6.0
) -> tuple[list[float], list[tuple[float, float, float]], list[tuple[float, float, float]]]:
    """A 0.5 m/s step at 1 s followed with a first-order lag `tau`: half the change after tau * ln 2."""
    times = [k * dt for k in range(round(seconds / dt))]
    commanded = [(0.5 if t >= 1.0 else 0.0, 0.0, 0.0) for t in times]
    measured = [(0.5 * (1 - math.exp(-(t - 1.0) / tau)) if t >= 1.0 else 0.0, 0.0, 0.0) for t in times]
    return times, commanded, measured


@pytest.mark.parametrize("tau", [0.2, 0.5])
def test_command_response_is_the_time_to_half_the_change(tau: float) -> None:
    mean, answered, unanswered = command_response_s(*first_order(tau), window_s=0.0)
    assert answered == 1 and unanswered == 0
    assert mean == pytest.approx(tau * math.log(2), abs=0.02)  # within one tick


def test_command_response_counts_changes_never_answered() -> None:
    times, commanded, _ = first_order(0.2)
    mean, answered, unanswered = command_response_s(times, commanded, [(0.0, 0.0, 0.0)] * len(times))
    assert math.isnan(mean) and answered == 0 and unanswered == 1


def test_plan_tracking_errors() -> None:
    qpos = np.array(g1.standing_qpos())
    qpos[g1.QPOS_ROOT_QUAT] = quat.from_yaw(0.3)
    plan = ReferenceSample(
        time=1.0, qpos=qpos, root_velocity=np.array([0.5, 0.0, 0.0]), yaw_rate=0.1, joint_velocity=np.zeros(29), held=False
    )
    joints = qpos[g1.QPOS_JOINTS].copy()
    joints[g1.joint_indices(g1.UPPER_BODY_JOINTS)] += 0.1
    state = RobotState(
        time=1.0, joint_pos=joints, joint_vel=np.zeros(29), base_quat=quat.from_yaw(0.1), base_ang_vel=np.zeros(3),
        base_pos=qpos[:3] + np.array([0.3, 0.4, 0.0]), base_lin_vel=np.zeros(3),
    )  # fmt: skip
    metrics = PlanTrackingMetrics()
    metrics.record(1.0, state, plan)
    report = metrics.report()
    assert report["root_path_error_mean"] == pytest.approx(0.5)
    assert report["heading_error_mean"] == pytest.approx(0.2)
    assert report["upper_body_error_mean"] == pytest.approx(0.1)
    vx, vy, wz = metrics.planned[0]
    assert (vx, vy, wz) == pytest.approx((0.5 * math.cos(0.3), -0.5 * math.sin(0.3), 0.1))
