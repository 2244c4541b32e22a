"""Foot locking: the numpy leg chains match MuJoCo, and a stance foot stops sliding without touching keyframes."""

from __future__ import annotations

import numpy as np

from controller.planner.foot_lock import LegChains, lock_feet
from hw import quat
from sim.kinematics import leg_chain_specs
from tests.conftest import turning_walk


def test_leg_chains_match_mujoco_forward_kinematics(g1_model) -> None:  # type: ignore[no-untyped-def]
    legs = LegChains.from_spec(leg_chain_specs(g1_model))
    qpos = turning_walk(40)
    import mujoco

    data = mujoco.MjData(g1_model)
    for t in (0, 17, 39):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(g1_model, data)
        for side, body in enumerate(("left_foot_contact_point", "right_foot_contact_point")):
            leg = qpos[t, None, 7 + 6 * side : 13 + 6 * side]
            sole, _, _ = legs.forward(qpos[t, None, :3], quat.to_matrix(qpos[t, None, 3:7]), leg, np.array([side]))
            assert np.allclose(sole[0], data.xpos[g1_model.body(body).id], atol=1e-9)


def test_stance_foot_is_pinned_and_keyframes_stay_exact(g1_model) -> None:  # type: ignore[no-untyped-def]
    legs = LegChains.from_spec(leg_chain_specs(g1_model))
    qpos = turning_walk(32)[None]  # the root glides while the legs wave: every foot slides
    contacts = np.zeros((1, 32, 2), dtype=bool)
    contacts[0, 5:15, 0] = True
    fixed = np.zeros((32, 2), dtype=bool)
    fixed[10, :] = True  # a keyframe constrains both legs at frame 10
    locked = lock_feet(qpos, contacts, legs, turning_walk(32)[0], fixed)

    def left_sole(q: np.ndarray) -> np.ndarray:
        return legs.forward(q[:, :3], quat.to_matrix(q[:, 3:7]), q[:, 7:13], np.zeros(len(q), dtype=np.intp))[0]

    before, after = left_sole(qpos[0]), left_sole(locked[0])
    drift_before = np.linalg.norm(np.diff(before[5:15, :2], axis=0), axis=-1).mean()
    drift_after = np.linalg.norm(np.diff(after[5:15, :2], axis=0), axis=-1).mean()
    assert drift_after < 0.2 * drift_before
    assert np.allclose(after[5:15, :2], before[10, :2], atol=0.01)  # pinned where the keyframe puts the foot
    assert np.array_equal(locked[0, 10], qpos[0, 10])  # the keyframe frame is untouched
    assert np.array_equal(locked[0, 20:], qpos[0, 20:])  # so is everything past the fade
    assert np.array_equal(locked[0, :, 13:], qpos[0, :, 13:]) and np.array_equal(locked[0, :, :7], qpos[0, :, :7])
