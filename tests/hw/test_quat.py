"""Quaternion helpers (hw/quat.py) on rotations with known answers, batched over leading dimensions."""

from __future__ import annotations

import numpy as np
import pytest

from hw import quat

RNG = np.random.default_rng(7)


def test_quaternion_helpers() -> None:
    q = quat.normalize(RNG.normal(size=(5, 4)))
    np.testing.assert_allclose(quat.multiply(q, quat.conjugate(q)), np.tile([1.0, 0, 0, 0], (5, 1)), atol=1e-12)
    np.testing.assert_allclose(quat.angle(q, -q), 0.0, atol=1e-6)
    np.testing.assert_allclose(np.abs(np.sum(quat.exp(quat.log(q)) * q, axis=-1)), 1.0, atol=1e-12)
    assert quat.angle(quat.from_yaw(0.0), quat.from_yaw(0.5)) == pytest.approx(0.5)
    assert quat.heading(quat.from_yaw(2.0)) == pytest.approx(2.0)
    mid = quat.slerp(quat.from_yaw(0.0), quat.from_yaw(np.pi / 2), 0.5)
    np.testing.assert_allclose(mid, quat.from_yaw(np.pi / 4), atol=1e-12)
    np.testing.assert_allclose(quat.slerp(quat.from_yaw(0.0), -quat.from_yaw(np.pi / 2), 0.5), mid, atol=1e-12)  # the short way
    np.testing.assert_allclose(quat.rotate(quat.from_yaw(np.pi / 2), [1.0, 0, 0]), [0.0, 1.0, 0.0], atol=1e-12)


def test_continuous_flips_signs_along_time() -> None:
    flipped = np.array([quat.from_yaw(0.1), -quat.from_yaw(0.2), quat.from_yaw(0.3)])
    fixed = quat.continuous(flipped, axis=0)
    assert (np.sum(fixed[1:] * fixed[:-1], axis=-1) > 0).all()
    q = np.array([[1.0, 0, 0, 0], [-1.0, 0, 0, 0], [-0.9, 0, 0, -0.1]])
    assert (quat.continuous(q)[:, 0] > 0).all()


def test_from_yaw_and_from_axis_angle() -> None:
    yaw = RNG.uniform(-4.0, 4.0, size=(3, 2))
    q = quat.from_yaw(yaw)
    assert q.shape == (3, 2, 4)
    np.testing.assert_allclose(q, quat.exp(np.stack((0 * yaw, 0 * yaw, yaw), axis=-1)), atol=1e-12)
    np.testing.assert_allclose(quat.from_axis_angle([0.0, 0.0, 5.0], yaw), q, atol=1e-12)  # the axis length does not matter
    np.testing.assert_allclose(quat.wrap_angle(quat.heading(q) - yaw), 0.0, atol=1e-12)
    axis = RNG.normal(size=(4, 3))
    angle = RNG.uniform(0.0, 3.0, size=4)
    np.testing.assert_allclose(quat.angle(quat.from_axis_angle(axis, angle), [1.0, 0, 0, 0]), angle, atol=1e-9)
    np.testing.assert_allclose(quat.rotate(quat.from_axis_angle(axis, angle), axis), axis, atol=1e-12)  # the axis stays put


def test_to_matrix_rotates_like_rotate() -> None:
    q = quat.normalize(RNG.normal(size=(2, 3, 4)))
    v = RNG.normal(size=(2, 3, 3))
    m = quat.to_matrix(q)
    assert m.shape == (2, 3, 3, 3)
    np.testing.assert_allclose((m @ v[..., None])[..., 0], quat.rotate(q, v), atol=1e-12)
    np.testing.assert_allclose(m @ np.swapaxes(m, -1, -2), np.broadcast_to(np.eye(3), m.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(m), 1.0, atol=1e-12)
    np.testing.assert_allclose(quat.to_matrix(-3.0 * q), m, atol=1e-12)  # normalized first; q and -q are one rotation
    np.testing.assert_allclose(quat.to_matrix(quat.from_yaw(np.pi / 2)), [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12)


def test_rpy_inverts_yaw_pitch_roll() -> None:
    roll, pitch, yaw = RNG.uniform(-3.0, 3.0, 6), RNG.uniform(-1.5, 1.5, 6), RNG.uniform(-3.0, 3.0, 6)
    q = quat.multiply(
        quat.from_yaw(yaw), quat.multiply(quat.from_axis_angle([0.0, 1.0, 0.0], pitch), quat.from_axis_angle([1.0, 0.0, 0.0], roll))
    )
    got = quat.rpy(q)
    assert got.shape == (6, 3)
    np.testing.assert_allclose(got, np.stack((roll, pitch, yaw), axis=-1), atol=1e-9)
    np.testing.assert_allclose(got[..., 2], quat.heading(q), atol=1e-12)
    np.testing.assert_allclose(quat.rpy([1.0, 0.0, 0.0, 0.0]), [0.0, 0.0, 0.0], atol=1e-12)
    # Straight up, rounding may push the pitch sine past 1: it is clipped, not NaN.
    up = quat.from_axis_angle([0.0, 1.0, 0.0], np.pi / 2) * (1 + 1e-12)
    assert quat.rpy(up)[1] == pytest.approx(np.pi / 2)
