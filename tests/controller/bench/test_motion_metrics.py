"""In-betweening metrics and baselines on hand-made data with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from controller.bench import baselines
from controller.bench import motion_metrics as mt
from controller.planner.request import FPS, PlanRequestError
from hw import g1, quat

RNG = np.random.default_rng(7)


def frame(xyz: tuple[float, float, float] = (0.0, 0.0, 0.78), q: np.ndarray | None = None, joints: np.ndarray | None = None) -> np.ndarray:
    out = np.zeros(g1.QPOS_SIZE)
    out[:3] = xyz
    out[3:7] = (1.0, 0.0, 0.0, 0.0) if q is None else q
    out[7:] = g1.default_joint_vector() if joints is None else joints
    return out


def random_context() -> np.ndarray:
    """Four frames moving with some velocity, turning and tilting."""
    base = frame((0.1, -0.2, 0.76), quat.from_axis_angle([0.1, 0.2, 1.0], 0.4), RNG.uniform(-0.5, 0.5, g1.NUM_JOINTS))
    step = np.concatenate((RNG.uniform(-0.02, 0.02, 3), np.zeros(4), RNG.uniform(-0.03, 0.03, g1.NUM_JOINTS)))
    spin = quat.from_axis_angle([0.3, -0.1, 1.0], 0.05)
    frames = []
    q = base[3:7]
    for k in range(4):
        f = base + k * step
        f[3:7] = q
        q = quat.multiply(q, spin)
        frames.append(f)
    return np.array(frames)


# ---- metrics -------------------------------------------------------------------------------


def test_constant_velocity_has_zero_jitter_and_constant_acceleration_is_measured() -> None:
    t = np.arange(20)[:, None, None] / FPS
    velocity = np.array([[0.5, -0.2, 0.1], [1.0, 0.0, 0.0]])  # two bodies
    pos = np.zeros((20, 2, 3)) + velocity * t
    assert mt.joint_jitter(pos) == pytest.approx(0.0, abs=1e-9)
    assert mt.root_jitter(pos) == pytest.approx(0.0, abs=1e-9)
    accel = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 0.0]])
    pos = pos + 0.5 * accel * t**2
    assert mt.root_jitter(pos) == pytest.approx(0.0, abs=1e-9)  # body 0 still moves at constant velocity
    assert mt.joint_jitter(pos) == pytest.approx(2.5)  # mean of 0 and 5 m/s^2
    assert mt.joint_jitter(np.stack((pos, pos))) == pytest.approx(2.5)  # batches pool


def test_sliding_foot_has_known_skate_and_lifted_foot_does_not_count() -> None:
    frames = 31
    feet = np.zeros((frames, 2, 3))
    feet[:, 0, 0] = 0.3 * np.arange(frames) / FPS  # left foot on the ground sliding at 0.3 m/s
    feet[:, 1, 2] = 0.2  # right foot in the air, moving fast
    feet[:, 1, 1] = 2.0 * np.arange(frames) / FPS
    assert mt.foot_skate(feet) == pytest.approx(0.3)
    feet[20:, 0, 2] = 0.1  # the left foot lifts at frame 20 and moves faster
    feet[20:, 0, 0] += np.arange(frames - 20) * 0.1
    assert mt.foot_skate(feet) == pytest.approx(0.3)
    assert mt.foot_skate(np.full((5, 2, 3), 0.5)) == 0.0  # never in contact


def test_contact_rule_matches_the_kinematics_module() -> None:
    from sim.kinematics import foot_contacts

    feet = RNG.uniform(0.0, 0.1, size=(40, 2, 3))
    np.testing.assert_array_equal(mt.contacts(feet), foot_contacts(feet))


def test_npss_is_zero_for_identical_sequences_and_grows_with_spectral_change() -> None:
    t = np.arange(30)[:, None] / FPS
    smooth = np.hstack((np.sin(2 * np.pi * 0.5 * t), 0.3 + 0.1 * t, np.zeros_like(t)))
    assert mt.npss(smooth, smooth) == pytest.approx(0.0, abs=1e-12)
    assert mt.npss(np.stack((smooth, smooth)), np.stack((smooth, smooth))) == pytest.approx(0.0, abs=1e-12)
    jittery = smooth + 0.2 * np.sign(np.sin(2 * np.pi * 7 * t))
    noisy = smooth + 0.02 * np.sign(np.sin(2 * np.pi * 7 * t))
    assert 0 < mt.npss(noisy, smooth) < mt.npss(jittery, smooth)
    assert mt.npss(smooth * 2.0, smooth) == pytest.approx(0.0, abs=1e-12)  # scale-free: spectra are normalized


def test_position_rotation_and_target_errors() -> None:
    true = RNG.normal(size=(6, 5, 3))
    pred = true + np.array([0.03, 0.04, 0.0])
    assert mt.l2p(pred, true) == pytest.approx(0.05)
    q = quat.normalize(RNG.normal(size=(6, 5, 4)))
    assert mt.l2q(quat.multiply(q, quat.from_yaw(0.3)), q) == pytest.approx(0.3)
    assert mt.l2q(-q, q) == pytest.approx(0.0, abs=1e-6)
    bodies = np.zeros((4, 3))
    moved = bodies.copy()
    moved[2] = (0.0, 0.0, 0.07)
    assert mt.keyframe_error(moved, bodies) == pytest.approx(0.07)
    assert mt.root_error([0.03, 0.04, 1.0], [0.0, 0.0, 0.0]) == pytest.approx(0.05)  # horizontal only


def test_reach_needs_position_and_heading() -> None:
    target, heading = np.array([1.0, 2.0, 0.78]), quat.from_yaw(3.1)
    assert mt.reached(target + np.array([0.04, 0.0, 0.2]), quat.from_yaw(3.1 + np.deg2rad(10)), target, heading)  # wraps past pi
    assert not mt.reached(target + np.array([0.06, 0.0, 0.0]), heading, target, heading)
    assert not mt.reached(target, quat.from_yaw(3.1 - np.deg2rad(20)), target, heading)
    batch = mt.reached(
        np.stack((target, target + 1)), np.stack((heading, heading)), np.stack((target, target)), np.stack((heading, heading))
    )
    np.testing.assert_array_equal(batch, [True, False])


def test_diversity_is_mean_pairwise_distance() -> None:
    base = RNG.normal(size=(10, 4, 3))
    samples = np.stack([base + np.array([0.1 * k, 0.0, 0.0]) for k in range(3)])
    assert mt.diversity(samples) == pytest.approx((0.1 + 0.2 + 0.1) / 3)
    assert mt.diversity(samples[:1]) == 0.0
    assert mt.diversity(np.stack((base, base))) == 0.0


# ---- baselines -----------------------------------------------------------------------------


def cubic_at_start(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Value and derivative at s = 0 of the cubic through samples at s = 1, 2, 3, 4."""
    value = 4 * p[0] - 6 * p[1] + 4 * p[2] - p[3]
    slope = -(25 / 12) * value + 4 * p[0] - 3 * p[1] + (4 / 3) * p[2] - 0.25 * p[3]
    return value, slope


def cubic_at_end(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Value and derivative at s = S of the cubic through samples at s = S-4 .. S-1 (p in that order)."""
    value = 4 * p[3] - 6 * p[2] + 4 * p[1] - p[0]
    slope = (25 / 12) * value - 4 * p[3] + 3 * p[2] - (4 / 3) * p[1] + 0.25 * p[0]
    return value, slope


def test_baselines_start_at_the_context_and_end_at_the_target() -> None:
    context = random_context()
    target = frame((0.8, 0.4, 0.74), -quat.from_axis_angle([0.0, 0.3, 1.0], 1.2), RNG.uniform(-0.5, 0.5, g1.NUM_JOINTS))  # far hemisphere
    velocity = np.concatenate((RNG.uniform(-0.5, 0.5, 3), RNG.uniform(-1, 1, 3), RNG.uniform(-1, 1, g1.NUM_JOINTS)))
    length = 20
    lin = np.r_[0:3, 7:36]
    for out in (baselines.interp(context, target, length), baselines.hermite(context, target, length, velocity)):
        assert out.shape == (length, 36)
        np.testing.assert_allclose(np.linalg.norm(out[:, 3:7], axis=-1), 1.0, atol=1e-12)
        dots = np.sum(np.vstack((context[-1:, 3:7], out[:, 3:7]))[1:] * np.vstack((context[-1:, 3:7], out[:, 3:7]))[:-1], axis=-1)
        assert (dots > 0).all()  # sign-continuous from the context on
        np.testing.assert_allclose(cubic_at_start(out[:4, lin])[0], context[-1, lin], atol=1e-9)
        np.testing.assert_allclose(cubic_at_end(out[-4:, lin])[0], target[lin], atol=1e-9)
        q0 = context[-1, 3:7]
        h = quat.log(quat.multiply(quat.conjugate(q0), out[:, 3:7]))  # a cubic in s for hermite, linear for interp
        assert quat.angle(quat.exp(cubic_at_end(h[-4:])[0]), quat.multiply(quat.conjugate(q0), target[3:7])) < 1e-7
    mid = baselines.interp(context, target, 1)[0]
    np.testing.assert_allclose(mid[lin], (context[-1, lin] + target[lin]) / 2)
    held = baselines.zerovel(context, target, 7)
    np.testing.assert_allclose(held, np.tile(context[-1], (7, 1)), atol=1e-12)


def test_hermite_matches_the_context_velocity_at_the_start_and_the_target_velocity_at_the_end() -> None:
    context = random_context()
    target = frame((0.6, 0.1, 0.77), quat.from_axis_angle([0.2, 0.1, 1.0], 0.9), RNG.uniform(-0.5, 0.5, g1.NUM_JOINTS))
    velocity = np.concatenate((RNG.uniform(-0.5, 0.5, 3), RNG.uniform(-1, 1, 3), RNG.uniform(-1, 1, g1.NUM_JOINTS)))
    out = baselines.hermite(context, target, 25, velocity)
    lin, vlin = np.r_[0:3, 7:36], np.r_[0:3, 6:35]
    start_velocity = baselines.finite_velocity(context[-2], context[-1], fps=1.0)  # per frame
    np.testing.assert_allclose(cubic_at_start(out[:4, lin])[1], start_velocity[vlin], atol=1e-9)
    np.testing.assert_allclose(cubic_at_end(out[-4:, lin])[1], velocity[vlin] / FPS, atol=1e-9)
    h = quat.log(quat.multiply(quat.conjugate(context[-1, 3:7]), out[:, 3:7]))
    np.testing.assert_allclose(cubic_at_start(h[:4])[1], start_velocity[3:6], atol=1e-9)  # body angular velocity


def test_inverse_right_jacobian_maps_body_rates_to_rotation_vector_rates() -> None:
    for _ in range(5):
        phi, omega, eps = RNG.uniform(-1.5, 1.5, 3), RNG.normal(size=3), 1e-6
        moved = quat.exp(phi + eps * (baselines._inverse_right_jacobian(phi) @ omega))
        expected = quat.multiply(quat.exp(phi), quat.exp(eps * omega))
        assert quat.angle(moved, expected) < 1e-10


def test_hermite_and_interp_reproduce_uniform_motion() -> None:
    frames = np.array([frame((0.1 * k, 0.02 * k, 0.78), quat.from_yaw(0.05 * k), np.full(g1.NUM_JOINTS, 0.01 * k)) for k in range(30)])
    context, truth, target, after = frames[:4], frames[4:24], frames[24], frames[25]
    velocity = baselines.finite_velocity(target, after)
    np.testing.assert_allclose(velocity[3:6], [0.0, 0.0, 0.05 * FPS], atol=1e-9)
    np.testing.assert_allclose(baselines.hermite(context, target, 20, velocity), truth, atol=1e-9)
    np.testing.assert_allclose(baselines.interp(context, target, 20), truth, atol=1e-9)


def test_baselines_reject_bad_input() -> None:
    context, target = random_context(), frame()
    with pytest.raises(PlanRequestError, match="at least 1 frame"):
        baselines.interp(context, target, 0)
    with pytest.raises(PlanRequestError, match="context"):
        baselines.interp(context[:3], target, 5)
    with pytest.raises(PlanRequestError, match="target velocity"):
        baselines.hermite(context, target, 5, np.zeros(36))
