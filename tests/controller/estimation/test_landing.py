"""A foot that has just landed is still sliding from its impact: it counts only once it has settled."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.estimation.estimator import StateEstimator
from hw import g1
from hw.types import RobotState

LIFT = 0.2  # rad: the right hip and ankle pitch back by this, the knee bends by twice it: the right foot 5 cm up
SLIDE = 1.0  # rad/s of the right hip pitch: the right foot moves 0.65 m/s along the pelvis's x


def reading(t: float, right_lifted: bool, right_sliding: bool) -> RobotState:
    """The G1 level and still (the IMU reads gravity) on its left foot in the default pose; the right foot up or down,
    sliding or not. A base the IMU says is still, and a right foot that says the base moves at 0.65 m/s."""
    q, dq = np.array(g1.default_joint_vector()), np.zeros(g1.NUM_JOINTS)
    hip, knee, ankle = (g1.JOINT_NAMES.index(f"right_{j}_joint") for j in ("hip_pitch", "knee", "ankle_pitch"))
    if right_lifted:
        q[hip], q[knee], q[ankle] = q[hip] - LIFT, q[knee] + 2 * LIFT, q[ankle] - LIFT
    if right_sliding:
        dq[hip] = SLIDE
    return RobotState(
        time=t, joint_pos=q, joint_vel=dq, base_quat=np.array([1.0, 0.0, 0.0, 0.0]), base_ang_vel=np.zeros(3),
        base_pos=np.zeros(3), base_lin_vel=np.zeros(3), has_base_position=False, imu_accel=np.array([0.0, 0.0, 9.81]),
    )  # fmt: skip


def landing(estimator: StateEstimator, dt: float, updates: int) -> list[float]:
    """Half a second on the left foot, then the right foot lands sliding and keeps sliding: the estimate's forward
    velocity at each update from the landing on."""
    t = 0.0
    for _ in range(round(0.5 / dt)):
        estimator.update(reading(t, right_lifted=True, right_sliding=False))
        t += dt
    assert estimator.contacts == (True, False)
    speeds = []
    for _ in range(updates):
        speeds.append(float(estimator.update(reading(t, right_lifted=False, right_sliding=True)).base_lin_vel[0]))
        assert estimator.contacts == (True, True)
        t += dt
    return speeds


@pytest.mark.parametrize("dt", [0.02, 0.002], ids=["tracker rate", "bus rate"])
def test_a_landing_foot_counts_once_it_has_settled(dt: float) -> None:
    """The same reading of the sliding foot leaves the estimate still while the foot lands and moves it once it stands."""
    estimator = StateEstimator.for_g1(g1.JOINT_NAMES)
    settle = estimator.config.contact.settle_time
    landing_updates = math.floor(settle / dt + 1e-9) + 1  # the landing's own update, and those less than settle_time after
    speeds = landing(estimator, dt, landing_updates + 1)
    assert max(abs(v) for v in speeds[:landing_updates]) < 1e-5, speeds  # the left foot and the IMU alone: still
    assert speeds[landing_updates] > 0.05, speeds  # settled: the right foot counts
    assert estimator.fault is None
