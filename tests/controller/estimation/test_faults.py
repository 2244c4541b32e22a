"""The estimator watches itself: feet sliding under a still IMU, non-finite input, and on the simulator, a slippery floor."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from controller.estimation.estimator import StateEstimator
from controller.runtime.driver import run
from controller.runtime.run_config import RunConfig
from hw import g1
from hw.types import RobotState
from sim.perturbations import Perturbations

DT = 0.02  # the tracker's tick


def standing(t: float, joint_pos: np.ndarray | None = None, joint_vel: np.ndarray | None = None) -> RobotState:
    """The G1 standing level in its default pose, as hardware measures it: the IMU at rest reads gravity, up."""
    return RobotState(
        time=t, joint_pos=np.array(g1.default_joint_vector()) if joint_pos is None else joint_pos,
        joint_vel=np.zeros(g1.NUM_JOINTS) if joint_vel is None else joint_vel, base_quat=np.array([1.0, 0.0, 0.0, 0.0]),
        base_ang_vel=np.zeros(3), base_pos=np.zeros(3), base_lin_vel=np.zeros(3), has_base_position=False,
        imu_accel=np.array([0.0, 0.0, 9.81]),
    )  # fmt: skip


def sliding(estimator: StateEstimator, start: float, seconds: float, rate: float) -> float:
    """Both feet slide forward under a base the IMU says is still: the hip pitch joints turn at `rate` (rad/s)."""
    hips = [g1.JOINT_NAMES.index(name) for name in ("left_hip_pitch_joint", "right_hip_pitch_joint")]
    q, dq = np.array(g1.default_joint_vector()), np.zeros(g1.NUM_JOINTS)
    dq[hips] = -rate
    t = start
    for _ in range(round(seconds / DT)):
        t += DT
        q = q + dq * DT
        estimator.update(standing(t, q, dq))
        if estimator.fault is not None:
            break
    return t


def test_feet_sliding_under_a_still_imu_trip_the_slip_watch_and_standing_still_does_not() -> None:
    estimator = StateEstimator.for_g1(g1.JOINT_NAMES)
    for k in range(100):
        estimator.update(standing(k * DT))
    assert estimator.fault is None
    slow = sliding(estimator, 99 * DT, 0.3, 0.02)  # 1.5 cm/s at the feet: creeping, within the filter's noise
    assert estimator.fault is None
    tripped = sliding(estimator, slow, 0.5, 5.0)  # about 3.5 m/s at the feet, at once: feet breaking away on a slippery floor
    assert estimator.fault is not None and estimator.fault.startswith("feet slipping: the stance foot's velocity left the IMU's")
    assert tripped - slow <= 0.1, "a skid is caught within a few ticks"


def test_a_non_finite_input_latches_and_the_last_good_estimate_stays() -> None:
    estimator = StateEstimator.for_g1(g1.JOINT_NAMES)
    for k in range(10):
        good = estimator.update(standing(k * DT))
    bad = standing(10 * DT)
    bad.joint_pos[g1.JOINT_NAMES.index("left_knee_joint")] = math.nan
    out = estimator.update(bad)
    assert estimator.fault == "non-finite input: joint_pos (legs)"
    np.testing.assert_array_equal(out.base_pos, good.base_pos)
    later = estimator.update(standing(11 * DT))  # latched: good numbers do not clear it
    assert estimator.fault == "non-finite input: joint_pos (legs)" and np.isfinite(later.base_pos).all()
    np.testing.assert_array_equal(later.base_pos, good.base_pos)
    estimator.update(dataclasses.replace(standing(12 * DT), base_quat=np.full(4, math.nan)))
    assert estimator.fault == "non-finite input: joint_pos (legs)"  # the first cause is the one reported


@pytest.mark.slow
def test_a_slippery_floor_holds_the_waypoints_standing_and_a_normal_floor_does_not() -> None:
    """On the simulator with the estimator: a third of the friction makes the stance feet slide within a second or two."""
    slippery = run(RunConfig(scenario="waypoints", duration=3.0, estimator=True, perturbations=Perturbations(friction_scale=0.3)))
    assert slippery["final_mode"] == "stand" and "feet slipping" in slippery["hold_reason"]
    assert slippery["hold_time"] < 3.0
    normal = run(RunConfig(scenario="waypoints", duration=6.0, estimator=True))
    assert normal["final_mode"] == "run" and normal["hold_reason"] is None and normal["estimator"]["fault"] is None
    assert normal["falls"] == 0
