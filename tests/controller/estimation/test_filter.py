"""The estimator's Kalman filter against the textbook equations, written plainly in numpy, and a 1-D closed form."""

from __future__ import annotations

import numpy as np
import pytest

from controller.estimation.filter import NO_ROW, correct, predict

# The estimator's measurements, as (row, minus): left foot - base, right foot - base, base velocity twice.
MEASUREMENTS = ((2, 0), (3, 0), (1, NO_ROW), (1, NO_ROW))


def textbook(x, p, f, q, b, h, r, z):  # type: ignore[no-untyped-def]
    """Predict then correct all measurements at once, with an explicit inverse and the Joseph form of the covariance."""
    x, p = f @ x + b, f @ p @ f.T + q
    k = p @ h.T @ np.linalg.inv(h @ p @ h.T + r)
    i_kh = np.eye(len(x)) - k @ h
    return x + k @ (z - h @ x), i_kh @ p @ i_kh.T + k @ r @ k.T


def process_noise(q: np.ndarray, dt: float) -> np.ndarray:
    """diag(q), with the velocity's q[1] = s dt white acceleration noise of density s integrated into the position too:
    the textbook's s [[dt^3/3, dt^2/2], [dt^2/2, dt]] on (position, velocity)."""
    s = q[1] / dt
    noise = np.diag(q)
    noise[:2, :2] = s * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    noise[0, 0] += q[0]
    return noise


def test_one_step_matches_the_textbook_equations_column_by_column() -> None:
    rng = np.random.default_rng(3)
    dt = 0.02
    for _ in range(20):
        a = rng.normal(size=(4, 4))
        p = a @ a.T + 0.1 * np.eye(4)
        x, z, accel = rng.normal(size=(4, 3)), rng.normal(size=(4, 3)), rng.normal(size=3)
        q, r = rng.uniform(0.01, 1.0, 4), rng.uniform(0.01, 1.0, 4)
        x_new, p_new = x.copy(), p.copy()
        predict(x_new, p_new, dt, accel, q)
        for (row, minus), z_row, r_row in zip(MEASUREMENTS, z, r, strict=True):
            correct(x_new, p_new, row, minus, z_row, r_row)
        f = np.eye(4)
        f[0, 1] = dt
        h = np.zeros((4, 4))
        for i, (row, minus) in enumerate(MEASUREMENTS):
            h[i, row] = 1.0
            if minus != NO_ROW:
                h[i, minus] = -1.0
        b = np.outer([0.5 * dt * dt, dt, 0.0, 0.0], accel)
        for column in range(3):  # every column is its own filter sharing the covariance
            want_x, want_p = textbook(x[:, column], p, f, process_noise(q, dt), b[:, column], h, np.diag(r), z[:, column])
            np.testing.assert_allclose(x_new[:, column], want_x, atol=1e-12)
            np.testing.assert_allclose(p_new, want_p, atol=1e-12)
        np.testing.assert_array_equal(p_new, p_new.T)  # exactly symmetric


def test_a_control_input_adds_to_the_prediction() -> None:
    x = np.array([[1.0] * 3, [2.0] * 3, [0.0] * 3, [0.0] * 3])
    predict(x, np.eye(4), 0.1, np.array([1.0, 0.0, -1.0]), np.zeros(4))
    np.testing.assert_allclose(x[:2], [[1.205, 1.2, 1.195], [2.1, 2.0, 1.9]])


def test_a_scalar_measurement_weights_by_the_variances() -> None:
    """x ~ N(0, 4) measured as 3 with variance 1: the posterior is 3 * 4 / 5 with variance 4 * 1 / 5."""
    x = np.zeros((4, 3))
    p = np.diag([1.0, 4.0, 1.0, 1.0])
    correct(x, p, 1, NO_ROW, np.full(3, 3.0), 1.0)
    np.testing.assert_allclose(x[1], [2.4] * 3)
    np.testing.assert_allclose(p[1, 1], 0.8)


def test_an_acceleration_the_legs_deny_leaves_no_position_behind() -> None:
    """From a known state, one tick's acceleration sample a (say a foot's impact, sampled once): the prediction moves the
    position by a dt^2 / 2 and the velocity by a dt. A velocity measurement of the old velocity, trusted, takes both back:
    the position follows the velocity's correction through the covariance the acceleration noise gave them."""
    dt, a = 0.02, 10.0
    x, p = np.zeros((4, 3)), np.zeros((4, 4))
    predict(x, p, dt, np.array([a, 0.0, 0.0]), np.array([0.0, 0.25 * dt, 0.0, 0.0]))
    assert x[0, 0] == pytest.approx(0.5 * a * dt * dt) and x[1, 0] == pytest.approx(a * dt)
    correct(x, p, 1, NO_ROW, np.zeros(3), 1e-12)
    np.testing.assert_allclose(x[:2], 0.0, atol=1e-9)
