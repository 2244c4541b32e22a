"""The shipped planner (models/planner) loads with onnxruntime alone and plans plausible, constraint-exact motion."""

from __future__ import annotations

import numpy as np
import pytest

from controller.planner.request import Keyframe, PlanRequest, target_root
from controller.planner.runtime import Planner
from hw import g1, quat
from hw.shipped import model_dir
from tests.conftest import turning_walk

pytestmark = pytest.mark.skipif(not (model_dir("planner") / "planner.onnx").is_file(), reason="no shipped planner model")


def _standing() -> np.ndarray:
    return np.tile(g1.standing_qpos(), (4, 1))


def test_walks_from_standing_to_a_target_root() -> None:
    planner = Planner.load()
    plan = planner.plan(PlanRequest(_standing(), (target_root(43, 1.0, 0.3, 0.5),), lengths=(44,), seed=3))
    assert plan.qpos.shape == (44, 36) and plan.contacts.shape == (44, 2)
    assert np.allclose(plan.qpos[43, :2], [1.0, 0.3]) and np.isclose(quat.heading(plan.qpos[43, 3:7]), 0.5, atol=1e-3)
    assert np.all((plan.qpos[:, 2] > 0.6) & (plan.qpos[:, 2] < 0.9))  # the pelvis stays at walking height
    assert np.abs(plan.qpos[0, :3] - _standing()[-1, :3]).max() < 0.05  # continues the context
    steps = np.abs(np.diff(plan.qpos[:, g1.joint_slice(g1.LEG_JOINTS, qpos=True)], axis=0)).sum()
    assert steps > 1.0  # the legs move: it walks there rather than gliding
    assert plan.contacts.any(axis=1).mean() > 0.8  # mostly a foot on the ground


def test_arm_keyframe_is_met_and_seeds_differ() -> None:
    planner = Planner.load()
    pose = _standing()[-1].copy()
    pose[g1.joint_indices(["right_shoulder_pitch_joint"], qpos=True)] = -1.5
    arms = np.isin(g1.JOINT_NAMES, g1.ARM_JOINTS)
    request = PlanRequest(_standing(), (Keyframe(20, pose, joints=arms, root=False, root_height=False),), lengths=(32,), seed=0)
    plans, _ = planner.sample(request.validated(), [0, 1, 2])
    arm_columns = g1.joint_slice(g1.ARM_JOINTS, qpos=True)
    assert np.allclose(plans[:, 20, arm_columns], pose[arm_columns])
    assert np.ptp(plans[:, 25:, :2], axis=0).max() > 1e-3  # generative: the seeds disagree where nothing is constrained


def test_a_keyframe_with_its_velocity_takes_the_velocity_gain(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import json
    import shutil

    folder = tmp_path / "planner"
    shutil.copytree(model_dir("planner"), folder)
    spec = json.loads((folder / "planner.json").read_text())
    (folder / "planner.json").write_text(json.dumps(spec | {"residual_gain": 1.0, "velocity_residual_gain": 0.0}))
    target = _standing()[-1].copy()
    target[:2] += (0.4, 0.1)
    moving = np.zeros(35)
    moving[0] = 0.8  # m/s forward at the target
    with_velocity = PlanRequest(_standing(), (Keyframe(30, target, velocity=moving),), lengths=(32,), seed=0)
    plain = PlanRequest(_standing(), (Keyframe(30, target),), lengths=(32,), seed=0)
    both = Planner.load(folder, foot_lock=False)
    assert (both.residual_gain, both.velocity_residual_gain) == (1.0, 0.0)
    assert np.allclose(both.plan(with_velocity).qpos, Planner.load(folder, foot_lock=False, residual_gain=0.0).plan(with_velocity).qpos)
    assert np.allclose(both.plan(plain).qpos, Planner.load(folder, foot_lock=False, residual_gain=1.0).plan(plain).qpos)
    assert not np.allclose(both.plan(plain).qpos, Planner.load(folder, foot_lock=False, residual_gain=0.0).plan(plain).qpos)
    unset = spec.copy()
    unset.pop("velocity_residual_gain", None)
    (folder / "planner.json").write_text(json.dumps(unset | {"residual_gain": 0.5}))
    assert Planner.load(folder).velocity_residual_gain == 0.5  # a model without its own velocity gain uses the other


def test_the_fade_delay_and_the_context_feet_apply_only_where_keyframes_carry_velocities(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The loop and text plans give no keyframe velocities: their plans do not depend on either."""
    import json
    import shutil

    folder = tmp_path / "planner"
    shutil.copytree(model_dir("planner"), folder)
    spec = json.loads((folder / "planner.json").read_text())
    assert spec["velocity_fade_delay_frames"] == 8.0  # chosen on dance-B (MODEL_CARD.md)
    walk = turning_walk(40)
    moving = np.zeros(35)
    moving[0] = 0.6
    with_velocity = PlanRequest(walk[:4], (Keyframe(30, walk[34], velocity=moving),), lengths=(32,), seed=0)
    plain = PlanRequest(walk[:4], (Keyframe(30, walk[34]),), lengths=(32,), seed=0)
    shipped = Planner.load(folder)
    (folder / "planner.json").write_text(json.dumps(spec | {"velocity_fade_delay_frames": 0.0}))
    undelayed = Planner.load(folder)
    assert np.array_equal(shipped.plan(plain).qpos, undelayed.plan(plain).qpos)
    assert not np.allclose(shipped.plan(with_velocity).qpos, undelayed.plan(with_velocity).qpos)
