"""Smart locomotion requests: every plan continues a levelled context, so replanning cannot drift the pelvis over."""

from __future__ import annotations

import numpy as np
import pytest

from controller.inputs.base import VelocityCommand
from controller.planner.runtime import Planner
from controller.reference.locomotion import LocomotionConfig, SmartLocomotion, levelled
from controller.reference.scheduler import implausible_root
from hw import g1, quat
from hw.shipped import model_dir


def tilted_context(degrees: float, heading: float = 0.7) -> np.ndarray:
    frames = np.tile(np.array(g1.standing_qpos()), (4, 1))
    tilt = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(degrees))
    frames[:, g1.QPOS_ROOT_QUAT] = quat.multiply(quat.from_yaw(np.full(4, heading)), np.tile(tilt, (4, 1)))
    frames[:, 0] = np.arange(4) * 0.02  # walking forward
    return frames


def test_levelling_keeps_heading_position_and_joints_and_removes_the_tilt() -> None:
    context = tilted_context(25.0)
    level = levelled(context)
    assert implausible_root(context, 20.0, 1.0) is not None and implausible_root(level, 1e-6, 1.0) is None
    np.testing.assert_allclose(quat.heading(level[:, g1.QPOS_ROOT_QUAT]), quat.heading(context[:, g1.QPOS_ROOT_QUAT]), atol=1e-12)
    np.testing.assert_array_equal(level[:, :3], context[:, :3])
    np.testing.assert_array_equal(level[:, g1.QPOS_JOINTS], context[:, g1.QPOS_JOINTS])


def test_requests_continue_a_levelled_context_unless_told_not_to() -> None:
    locomotion = SmartLocomotion()
    locomotion.command = VelocityCommand(vx=0.4, yaw_rate=0.5)
    context = tilted_context(25.0)
    np.testing.assert_allclose(locomotion.request(context, 1.0).context, levelled(context))
    raw = SmartLocomotion(LocomotionConfig(level_context=False))
    np.testing.assert_array_equal(raw.request(context, 1.0).context, context)


@pytest.mark.skipif(not (model_dir("planner") / "planner.onnx").is_file(), reason="no shipped planner model")
def test_the_shipped_planner_starts_level_from_a_tilted_context() -> None:
    locomotion = SmartLocomotion()
    locomotion.command = VelocityCommand(vx=0.4)
    plan = Planner.load().plan(locomotion.request(tilted_context(30.0), 1.0))
    assert implausible_root(plan.qpos[:6], 10.0, 0.1) is None  # the frames the loop executes stay near level
