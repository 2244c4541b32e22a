"""The Kalman filter's two steps as pure functions.

The state may be a matrix: each column is one filter and all columns share one covariance. The
estimator runs x, y and z this way: the same motion model, the same measurement matrix and
isotropic noise give the three axes the same covariance, so one small filter serves all three
(a 4-state covariance instead of a 12-state one).
"""

from __future__ import annotations

import numpy as np

from hw.types import FloatArray


def predict(x: FloatArray, p: FloatArray, f: FloatArray, q: FloatArray, u: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """x' = F x + u, P' = F P F^T + Q."""
    x_next = f @ x if u is None else f @ x + u
    return x_next, f @ p @ f.T + q


def update(x: FloatArray, p: FloatArray, h: FloatArray, r: FloatArray, z: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Correct with measurement z = H x + noise(R): returns x', P' and the innovation z - H x.

    K = P H^T S^-1 with S = H P H^T + R, solved (S is symmetric positive definite), never inverted;
    P' = P - K S K^T, symmetrized against rounding.
    """
    ph_t = p @ h.T
    s = h @ ph_t + r
    gain = np.linalg.solve(s, ph_t.T).T
    innovation = z - h @ x
    p_next = p - gain @ s @ gain.T
    return x + gain @ innovation, 0.5 * (p_next + p_next.T), innovation
