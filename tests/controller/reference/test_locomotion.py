"""Smart locomotion requests: every plan continues a context whose pelvis tilt is capped, so replanning cannot tip it over."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.commands.velocity import VelocityCommand
from controller.planner.runtime import Planner
from controller.reference.locomotion import LocomotionConfig, SmartLocomotion, tilt_limited
from controller.reference.scheduler import implausible_root
from hw import g1, quat
from hw.shipped import model_dir


def tilted_context(degrees: float, heading: float = 0.7) -> np.ndarray:
    frames = np.tile(np.array(g1.standing_qpos()), (4, 1))
    tilt = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(degrees))
    frames[:, g1.QPOS_ROOT_QUAT] = quat.multiply(quat.from_yaw(np.full(4, heading)), np.tile(tilt, (4, 1)))
    frames[:, 0] = np.arange(4) * 0.02  # walking forward
    return frames


def test_a_steep_tilt_is_capped_keeping_heading_axis_position_and_joints() -> None:
    context = tilted_context(25.0)
    capped = tilt_limited(context, math.radians(10.0))
    assert implausible_root(capped, 10.0 + 1e-6, 1.0) is None and implausible_root(capped, 9.9, 1.0) is not None  # 10 degrees
    np.testing.assert_allclose(quat.heading(capped[:, g1.QPOS_ROOT_QUAT]), quat.heading(context[:, g1.QPOS_ROOT_QUAT]), atol=1e-12)
    np.testing.assert_array_equal(capped[:, :3], context[:, :3])
    np.testing.assert_array_equal(capped[:, g1.QPOS_JOINTS], context[:, g1.QPOS_JOINTS])
    mild = tilted_context(6.0)
    np.testing.assert_allclose(tilt_limited(mild, math.radians(10.0)), mild, atol=1e-12)  # a natural lean is kept


def test_requests_continue_a_capped_context_unless_told_not_to() -> None:
    locomotion = SmartLocomotion()
    locomotion.command = VelocityCommand(vx=0.4, yaw_rate=0.5)
    context = tilted_context(25.0)
    np.testing.assert_allclose(locomotion.request(context, 1.0).context, tilt_limited(context, math.radians(10.0)))
    raw = SmartLocomotion(LocomotionConfig(max_context_tilt_deg=None))
    np.testing.assert_array_equal(raw.request(context, 1.0).context, context)


@pytest.mark.skipif(not (model_dir("planner") / "planner.onnx").is_file(), reason="no shipped planner model")
def test_the_shipped_planner_continues_a_capped_context_near_the_cap() -> None:
    locomotion = SmartLocomotion()
    locomotion.command = VelocityCommand(vx=0.4)
    plan = Planner.load().plan(locomotion.request(tilted_context(40.0), 1.0))
    assert implausible_root(plan.qpos[:6], 20.0, 0.1) is None  # the frames the loop executes, not 40 degrees
