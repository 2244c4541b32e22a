"""Plausibility: frames beyond the motion data, joints beyond the limits, keyframes refused or out of reach."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.planner import plausibility as pl
from controller.planner.request import FPS, Keyframe, PlanRequest, PlanRequestError, target_root
from controller.planner.runtime import Planner
from hw import g1, quat
from hw.shipped import model_dir

SHIPPED = (model_dir("planner") / "planner.onnx").is_file()


def standing(frames: int = 4) -> np.ndarray:
    return np.tile(np.array(g1.standing_qpos()), (frames, 1))


def test_tilt_is_the_pelvis_axis_from_vertical_whatever_the_heading() -> None:
    frames = standing(3)
    frames[1, g1.QPOS_ROOT_QUAT] = quat.from_axis_angle([1.0, 0.0, 0.0], math.radians(30.0))
    frames[2, g1.QPOS_ROOT_QUAT] = quat.multiply(quat.from_yaw(2.0), quat.from_axis_angle([0.0, 1.0, 0.0], math.radians(70.0)))
    np.testing.assert_allclose(pl.tilt_deg(frames), [0.0, 30.0, 70.0], atol=1e-9)


def test_wild_frames_are_those_beyond_the_data_in_tilt_height_change_or_step() -> None:
    start = standing(1)[0]
    frames = standing(40)
    assert not pl.wild_frames(frames, start).any()  # standing still
    frames[5, g1.QPOS_ROOT_QUAT] = quat.from_axis_angle([0.0, 1.0, 0.0], math.radians(pl.MAX_TILT_DEG + 1.0))
    frames[10:, 2] -= np.minimum(np.arange(30) * 0.02, 0.35)  # sinks 0.02 m a frame (within the step), to 0.35 m below
    frames[30, 2] += 0.06  # one jump up: a step beyond the data, and the step back down after it
    wild = pl.wild_frames(frames, start)
    sunk = np.flatnonzero(np.abs(frames[:, 2] - start[2]) > pl.MAX_HEIGHT_CHANGE_M)
    assert sunk.min() > 10 and 30 not in sunk and 31 in sunk  # frame 30's jump lifts it back within the change bound
    assert set(np.flatnonzero(wild)) == {5, 30, *sunk.tolist()}  # frame 31 is wild by its change (0.33 m) alone
    batch = np.stack((frames, standing(40)))  # leading dimensions, one start each
    assert pl.wild_frames(batch, np.stack((start, start))).sum(axis=-1).tolist() == [wild.sum(), 0]


def test_joint_values_beyond_the_limits_are_counted_each() -> None:
    joints = np.array([g1.default_joint_vector()] * 2)
    knee = g1.JOINT_NAMES.index("left_knee_joint")
    joints[0, knee] = 3.0  # over 2.8798
    joints[1, knee] = -0.0873  # under -0.087267 by 3e-5
    assert pl.beyond_limits(joints).sum() == 2
    assert pl.beyond_limits(joints, tolerance=1e-4).sum() == 1


def test_a_keyframe_beyond_the_limits_or_not_finite_is_refused_naming_joint_and_frame() -> None:
    pose = standing(1)[0]
    knee, elbow = g1.joint_indices(["left_knee_joint", "right_elbow_joint"], qpos=True)
    cases = {
        "keyframe at frame 12: left_knee_joint is 3.1000 rad, outside the G1's limits [-0.087267, 2.8798]": (12, knee, 3.1),
        "keyframe at frame 7: right_elbow_joint is nan; send finite values": (7, elbow, math.nan),
        "keyframe at frame 3: root y is inf": (3, 1, math.inf),
    }  # fmt: skip
    for message, (frame, column, value) in cases.items():
        bad = pose.copy()
        bad[column] = value
        with pytest.raises(PlanRequestError) as caught:
            PlanRequest(standing(), (Keyframe(frame, bad),), (44,)).validated()
        assert str(caught.value).startswith(message) and "\n" not in str(caught.value)
    # A joint the keyframe leaves free is not asked for: its value is not judged. One at its limit in float32 is kept.
    free = pose.copy()
    free[knee] = 3.1
    legs_free = ~np.isin(g1.JOINT_NAMES, g1.LEG_JOINTS)
    PlanRequest(standing(), (Keyframe(12, free, joints=legs_free),), (44,)).validated()
    at_limit = pose.copy()
    at_limit[knee] = float(np.float32(2.8798))  # 2.87980008: above the limit by 8e-8
    PlanRequest(standing(), (Keyframe(12, at_limit),), (44,)).validated()


def test_out_of_reach_says_how_far_and_where_it_could_be_met() -> None:
    start = standing(1)[0]
    assert pl.out_of_reach(start, [1.0, 0.0], 43, FPS, 64) is None  # 0.68 m/s
    near_miss = pl.out_of_reach(start, [2.0, 0.0], 43, FPS, 64)
    assert near_miss is not None and "2.00 m" in near_miss and "1.36 m/s over 1.47 s" in near_miss
    assert "place it at frame 46 or later" in near_miss  # 2 m at 1.2892 m/s: 47 frames
    far = pl.out_of_reach(start, [10.0, 0.0], 43, FPS, 64)
    assert far is not None and "no plan (at most 64 frames) reaches it" in far


@pytest.mark.skipif(not SHIPPED, reason="no shipped planner model")
def test_the_planner_says_when_a_target_is_out_of_reach() -> None:
    planner = Planner.load()
    near = planner.plan(PlanRequest(standing(), (target_root(43, 1.0, 0.3, 0.5),), (44,)))
    assert near.unreachable is None
    far = planner.plan(PlanRequest(standing(), (target_root(43, 10.0, 0.0, 0.0),), (44,)))
    assert far.unreachable is not None and "frame 43 is 10.00 m from the context's root" in far.unreachable
    assert np.allclose(far.qpos[43, :2], [10.0, 0.0])  # met anyway: the keyframe is a hard constraint, hence the warning
    speed = np.linalg.norm(np.diff(far.qpos[:, :2], axis=0), axis=1).max() * FPS
    assert speed > 3 * pl.MAX_REACH_SPEED_MPS  # what a silent plan would have handed on
