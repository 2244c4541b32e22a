"""The estimator's Kalman filter, written for its structure and compiled: a handful of numbers per tick.

The state is a matrix: each column is one filter (world x, y, z) and all columns share one
covariance. The same motion model, the same measurement matrix and isotropic noise give the
three axes the same covariance, so one 4-state covariance serves all three instead of a
12-state one. Rows: the base position, the base velocity, the left and the right foot's contact
points. The two steps work in place and use the structure: the motion model only adds velocity
to position, and every measurement is one row of the state or a difference of two, with its own
variance (the noise is uncorrelated), so the correction is a sequence of scalar ones: the same
posterior as the joint update (tests/controller/estimation/test_filter.py checks both against
the textbook). They are compiled (numba) because at this size an interpreter's cost per
operation, not the arithmetic, is the bill.
"""

from __future__ import annotations

from numba import njit

from hw.types import FloatArray

NO_ROW = -1  # `correct`'s `minus` when the measurement is one row of the state, not a difference of two


@njit(cache=True)
def predict(x: FloatArray, p: FloatArray, dt: float, accel: FloatArray, q: FloatArray) -> None:
    """x' = F x + B a, P' = F P F^T + Q, in place on x (4, 3) and p (4, 4); F adds dt times the velocity (row 1)
    to the position (row 0), B = (dt^2 / 2, dt, 0, 0): `accel` (3) drives the velocity.

    Q is diag(q) but for the velocity's noise, white noise on the acceleration, which the position integrates too: the
    velocity gains q[1] = s dt (s its density), the position s dt^3 / 3 = q[1] dt^2 / 3 more, and the two covary by
    s dt^2 / 2 = q[1] dt / 2 (the continuous white-noise acceleration model). Without that covariance a correction of
    the velocity leaves the position as the acceleration sample moved it, and one sample a tick is a poor average of
    a foot's impact (docs/estimation.md).
    """
    half = 0.5 * dt * dt
    for axis in range(3):
        x[0, axis] += dt * x[1, axis] + half * accel[axis]
        x[1, axis] += dt * accel[axis]
    p[0, 0] += dt * (2.0 * p[0, 1] + dt * p[1, 1]) + q[1] * dt * dt / 3.0
    p[0, 1] += dt * p[1, 1] + 0.5 * q[1] * dt
    for j in range(2, 4):
        p[0, j] += dt * p[1, j]
    for j in range(1, 4):
        p[j, 0] = p[0, j]
    for i in range(4):
        p[i, i] += q[i]


@njit(cache=True)
def correct(x: FloatArray, p: FloatArray, row: int, minus: int, z: FloatArray, r: float) -> None:
    """Correct with the measurement z (3) = x[row] - x[minus] (x[row] where `minus` is NO_ROW) + noise of variance `r`, in
    place: K = P h / s with s = h P h + r; x' = x + K (z - h x); P' = P - (P h)(P h)^T / s."""
    if minus == NO_ROW:
        ph = (p[0, row], p[1, row], p[2, row], p[3, row])
        s = ph[row] + r
        e0, e1, e2 = z[0] - x[row, 0], z[1] - x[row, 1], z[2] - x[row, 2]
    else:
        ph = (p[0, row] - p[0, minus], p[1, row] - p[1, minus], p[2, row] - p[2, minus], p[3, row] - p[3, minus])
        s = ph[row] - ph[minus] + r
        e0, e1, e2 = z[0] - (x[row, 0] - x[minus, 0]), z[1] - (x[row, 1] - x[minus, 1]), z[2] - (x[row, 2] - x[minus, 2])
    inverse = 1.0 / s
    for i in range(4):
        gain = ph[i] * inverse
        x[i, 0] += gain * e0
        x[i, 1] += gain * e1
        x[i, 2] += gain * e2
        # ph_i ph_j / s, multiplied in this order, is the same float as ph_j ph_i / s: P stays exactly symmetric
        for j in range(4):
            p[i, j] -= ph[i] * ph[j] * inverse
