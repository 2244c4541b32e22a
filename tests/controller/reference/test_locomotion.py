"""Smart locomotion requests: the pelvis brought back upright early in every plan, so replanning cannot drift it."""

from __future__ import annotations

import numpy as np
import pytest

from controller.inputs.base import VelocityCommand
from controller.planner.runtime import Planner
from controller.reference.locomotion import LocomotionConfig, SmartLocomotion
from controller.reference.scheduler import implausible_root
from hw import g1, quat
from hw.shipped import model_dir


def tilted_context(degrees: float) -> np.ndarray:
    frame = np.array(g1.standing_qpos())
    frame[g1.QPOS_ROOT_QUAT] = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(degrees))
    return np.tile(frame, (4, 1))


def test_every_request_holds_the_pelvis_upright_at_the_standing_height_on_the_upright_frame() -> None:
    locomotion = SmartLocomotion()
    locomotion.command = VelocityCommand(vx=0.4, yaw_rate=0.5)
    upright = [k for k in locomotion.request(tilted_context(10.0), 1.0).keyframes if k.frame == 4]
    assert len(upright) == 1 and upright[0].root_height and not upright[0].root and not upright[0].joints.any()
    assert upright[0].qpos[2] == g1.STANDING_PELVIS_HEIGHT
    assert implausible_root(upright[0].qpos[None], 0.5, (0.7, 0.9)) is None  # level
    off = SmartLocomotion(LocomotionConfig(upright_frame=None))
    assert [k.frame for k in off.request(tilted_context(10.0), 1.0).keyframes] == [43]


def test_a_wave_keyframe_on_the_upright_frame_merges_into_it() -> None:
    locomotion = SmartLocomotion(LocomotionConfig(upright_frame=5))  # the wave's keyframes: 43, 41, ..., 5, 3
    locomotion.set_gesture("wave", 0.0)
    keyframes = locomotion.request(tilted_context(0.0), 1.0).keyframes
    frames = [k.frame for k in keyframes]
    assert len(set(frames)) == len(frames) and frames == sorted(frames)
    five = keyframes[frames.index(5)]
    assert five.root_height and five.joints.any()


@pytest.mark.skipif(not (model_dir("planner") / "planner.onnx").is_file(), reason="no shipped planner model")
def test_the_shipped_planner_levels_a_tilted_context_by_the_upright_frame() -> None:
    plan = Planner.load().plan(SmartLocomotion().request(tilted_context(12.0), 1.0))
    assert implausible_root(plan.qpos[:1], 8.0, (0.5, 1.1)) is not None  # it leaves the context tilted
    assert implausible_root(plan.qpos[4:5], 0.5, (0.77, 0.79)) is None  # level at the standing height on frame 4
