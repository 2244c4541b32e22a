"""The Kalman filter's steps against the textbook equations, written plainly, and a 1-D closed form."""

from __future__ import annotations

import numpy as np

from controller.estimation.filter import predict, update


def textbook(x, p, f, q, h, r, z):  # type: ignore[no-untyped-def]
    """Predict then correct, with an explicit inverse and the Joseph form of the covariance."""
    x, p = f @ x, f @ p @ f.T + q
    k = p @ h.T @ np.linalg.inv(h @ p @ h.T + r)
    i_kh = np.eye(len(x)) - k @ h
    return x + k @ (z - h @ x), i_kh @ p @ i_kh.T + k @ r @ k.T


def test_one_step_matches_the_textbook_equations_column_by_column() -> None:
    rng = np.random.default_rng(3)
    n, m, k = 4, 5, 3
    a = rng.normal(size=(n, n))
    p = a @ a.T + np.eye(n)
    f, h = np.eye(n) + 0.1 * rng.normal(size=(n, n)), rng.normal(size=(m, n))
    q, r = np.diag(rng.uniform(0.1, 1, n)), np.diag(rng.uniform(0.1, 1, m))
    x, z = rng.normal(size=(n, k)), rng.normal(size=(m, k))
    x_pred, p_pred = predict(x, p, f, q)
    x_new, p_new, innovation = update(x_pred, p_pred, h, r, z)
    for column in range(k):  # every column is its own filter sharing the covariance
        want_x, want_p = textbook(x[:, column], p, f, q, h, r, z[:, column])
        np.testing.assert_allclose(x_new[:, column], want_x, atol=1e-12)
        np.testing.assert_allclose(p_new, want_p, atol=1e-12)
    np.testing.assert_allclose(innovation, z - h @ (f @ x), atol=1e-12)


def test_a_control_input_adds_to_the_prediction() -> None:
    f = np.array([[1.0, 0.1], [0.0, 1.0]])
    x, u = np.array([[1.0], [2.0]]), np.array([[0.005], [0.1]])
    x_pred, _ = predict(x, np.eye(2), f, np.zeros((2, 2)), u)
    np.testing.assert_allclose(x_pred, [[1.205], [2.1]])


def test_a_scalar_measurement_weights_by_the_variances() -> None:
    """x ~ N(0, 4) measured as 3 with variance 1: the posterior is 3 * 4 / 5 with variance 4 * 1 / 5."""
    x, p, _ = update(np.zeros(1), np.array([[4.0]]), np.eye(1), np.eye(1), np.array([3.0]))
    np.testing.assert_allclose(x, [2.4])
    np.testing.assert_allclose(p, [[0.8]])
