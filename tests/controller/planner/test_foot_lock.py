"""Foot locking: the numpy leg chains match MuJoCo, and a stance foot stops sliding without touching keyframes."""

from __future__ import annotations

import numpy as np

from controller.planner.foot_lock import MOVING_FOOT_MPS, LegChains, lock_feet
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


def _left_sole(legs: LegChains, q: np.ndarray) -> np.ndarray:
    return legs.forward(q[:, :3], quat.to_matrix(q[:, 3:7]), q[:, 7:13], np.zeros(len(q), dtype=np.intp))[0]


def _left_stance(frames: slice) -> np.ndarray:
    contacts = np.zeros((1, 32, 2), dtype=bool)
    contacts[0, frames, 0] = True
    return contacts


def test_a_stance_foot_is_pinned_where_it_lands(g1_model) -> None:  # type: ignore[no-untyped-def]
    legs = LegChains.from_spec(leg_chain_specs(g1_model))
    qpos = turning_walk(32)[None]  # the root glides while the legs wave: every foot slides
    locked = lock_feet(qpos, _left_stance(slice(5, 15)), legs, qpos[0, 0], np.zeros((32, 2), dtype=bool), 30.0)
    before, after = _left_sole(legs, qpos[0]), _left_sole(legs, locked[0])
    drift_before = np.linalg.norm(np.diff(before[5:15, :2], axis=0), axis=-1).mean()
    drift_after = np.linalg.norm(np.diff(after[5:15, :2], axis=0), axis=-1).mean()
    assert drift_before > 0.005 and drift_after < 0.2 * drift_before
    assert np.allclose(after[5:15, :2], before[5, :2], atol=0.02)  # one damped step per frame: most of the glide, not all
    assert np.array_equal(locked[0, 20:], qpos[0, 20:])  # nothing past the fade moves
    assert np.array_equal(locked[0, :, 13:], qpos[0, :, 13:]) and np.array_equal(locked[0, :, :7], qpos[0, :, :7])


def _slowed(walk: np.ndarray, share: float) -> np.ndarray:
    """`walk` [T, 36] with the root and joints moving `share` as far from the first frame, the root turned as at first."""
    slow = walk[0] + share * (walk - walk[0])
    slow[:, 3:7] = walk[0, 3:7]
    return slow


def test_a_stance_that_holds_a_keyframe_goes_straight_to_its_foot(g1_model) -> None:  # type: ignore[no-untyped-def]
    legs = LegChains.from_spec(leg_chain_specs(g1_model))
    qpos = _slowed(turning_walk(32), 0.1)[None]  # the foot slides slower than a planted foot of capture
    fixed = np.zeros((32, 2), dtype=bool)
    fixed[10, :] = True  # a keyframe constrains both legs at frame 10
    locked = lock_feet(qpos, _left_stance(slice(5, 15)), legs, qpos[0, 0], fixed, 30.0)
    before, after = _left_sole(legs, qpos[0]), _left_sole(legs, locked[0])
    assert np.linalg.norm(before[10, :2] - before[5, :2]) * 30.0 / 5 < MOVING_FOOT_MPS
    assert np.linalg.norm(before[14, :2] - before[10, :2]) > 0.002
    line = before[5, :2] + np.linspace(0.0, 1.0, 6)[:, None] * (before[10, :2] - before[5, :2])
    assert np.allclose(after[5:11, :2], line, atol=0.001)  # from where it lands, straight to the keyframe's foot
    assert np.allclose(after[10:15, :2], before[10, :2], atol=0.001)  # then held there
    assert np.array_equal(locked[0, 10], qpos[0, 10])  # the keyframe frame is untouched
    assert np.array_equal(locked[0, 20:], qpos[0, 20:])


def test_a_stance_whose_keyframe_is_a_step_away_is_left_as_planned(g1_model) -> None:  # type: ignore[no-untyped-def]
    legs = LegChains.from_spec(leg_chain_specs(g1_model))
    qpos = turning_walk(32)[None]
    fixed = np.zeros((32, 2), dtype=bool)
    fixed[16, :] = True  # the keyframe comes in the run's fade-out
    before = _left_sole(legs, qpos[0])
    assert np.linalg.norm(before[16, :2] - before[5, :2]) * 30.0 / 11 > MOVING_FOOT_MPS
    locked = lock_feet(qpos, _left_stance(slice(5, 15)), legs, qpos[0, 0], fixed, 30.0)
    assert np.allclose(locked, qpos)
    gentle = _slowed(turning_walk(32), 0.1)[None]  # the same run, with the keyframe's foot near: pinned on the way to it
    assert not np.allclose(lock_feet(gentle, _left_stance(slice(5, 15)), legs, gentle[0, 0], fixed, 30.0), gentle)


def test_a_stance_from_the_first_frame_whose_foot_was_moving_is_left_as_planned(g1_model) -> None:  # type: ignore[no-untyped-def]
    """Given the frame before the context's last (the runtime does where keyframes carry velocities), a run from frame 0
    is a step when the context's own foot was moving faster than a planted foot slides."""
    legs = LegChains.from_spec(leg_chain_specs(g1_model))
    walk = turning_walk(40)
    context_before, context_last, qpos = walk[6], walk[7], walk[None, 8:40]
    feet = _left_sole(legs, walk[6:8])
    assert np.linalg.norm(feet[1, :2] - feet[0, :2]) * 30.0 > MOVING_FOOT_MPS  # the left foot leaves the context moving
    free = np.zeros((32, 2), dtype=bool)
    stance = _left_stance(slice(0, 10))
    pinned = lock_feet(qpos, stance, legs, context_last, free, 30.0)
    assert not np.allclose(pinned, qpos)  # without the frame before, pinned where the context left it
    assert np.array_equal(lock_feet(qpos, stance, legs, context_last, free, 30.0, context_before), qpos)
    # A foot that stood still in the context is pinned as before.
    still = walk[7].copy()
    assert np.array_equal(lock_feet(qpos, stance, legs, context_last, free, 30.0, still), pinned)
