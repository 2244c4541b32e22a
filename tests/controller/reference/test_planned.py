"""The planned reference keeps the plan on the robot: a drifted plan is moved rigidly onto the measured root."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.commands.velocity import VelocityCommand
from controller.reference.locomotion import SmartLocomotion
from controller.reference.planned import shift_frames
from hw import g1, quat


def test_shift_frames_puts_the_source_pose_on_the_target_rigidly() -> None:
    frames = np.tile(np.array(g1.standing_qpos()), (3, 1))
    frames[:, 0] = [0.0, 0.1, 0.2]  # walking along +x
    moved = shift_frames(frames, np.array([0.0, 0.0, 0.0]), np.array([1.0, 2.0, math.pi / 2]))
    np.testing.assert_allclose(moved[:, :2], [[1.0, 2.0], [1.0, 2.1], [1.0, 2.2]], atol=1e-12)  # now along +y
    np.testing.assert_allclose(quat.heading(moved[:, g1.QPOS_ROOT_QUAT]), math.pi / 2, atol=1e-12)
    np.testing.assert_array_equal(moved[:, g1.QPOS_JOINTS], frames[:, g1.QPOS_JOINTS])


def test_the_spring_continues_across_requests_whatever_the_plan_did() -> None:
    """The next target comes from the previous root path's rates, not from the plan's own speed (no feedback)."""
    locomotion = SmartLocomotion()
    locomotion.command = VelocityCommand(vx=0.5)
    standing = np.tile(np.array(g1.standing_qpos()), (4, 1))
    first = locomotion.request(standing, 0.0)
    racing = standing.copy()
    racing[:, 0] = [0.0, 0.1, 0.2, 0.3]  # a plan that ran at 3 m/s
    second = locomotion.request(racing, 0.1)
    path = locomotion.path
    assert path is not None
    # The spring's speed at the second request continues the first path (about 0.2 m/s after 0.1 s), not 3 m/s.
    assert 0.02 < path.velocities[0, 0] < 0.5
    assert second.keyframes[-1].qpos[0] - racing[-1, 0] == pytest.approx(first.keyframes[-1].qpos[0], abs=0.25)
