"""The estimator's Kalman filter, written for its structure in plain floats: a handful of numbers per tick.

The state is a matrix: each column is one filter (world x, y, z) and all columns share one
covariance. The same motion model, the same measurement matrix and isotropic noise give the
three axes the same covariance, so one 4-state covariance serves all three instead of a
12-state one. Rows: the base position, the base velocity, the left and the right foot's contact
points. At this size numpy's cost per call outweighs the arithmetic, so the two steps work on
lists in place, and use the structure: the motion model only adds velocity to position, and
every measurement is one row of the state or a difference of two, with its own variance (the
noise is uncorrelated), so the correction is a sequence of scalar ones: the same posterior as
the joint update (tests/controller/estimation/test_filter.py checks both against the textbook).
"""

from __future__ import annotations

from collections.abc import Sequence

Rows = list[list[float]]  # the state: 4 rows of 3 columns; the covariance: 4 x 4


def predict(x: Rows, p: Rows, dt: float, accel: Sequence[float], q: Sequence[float]) -> None:
    """x' = F x + B a, P' = F P F^T + diag(q), in place; F adds dt times the velocity (row 1) to the position (row 0),
    B = (dt^2 / 2, dt, 0, 0): `accel` (3) drives the velocity."""
    half = 0.5 * dt * dt
    position, velocity = x[0], x[1]
    for axis in range(3):
        position[axis] += dt * velocity[axis] + half * accel[axis]
        velocity[axis] += dt * accel[axis]
    p0, p1 = p[0], p[1]
    p0[0] += dt * (2.0 * p0[1] + dt * p1[1])
    for j in range(1, 4):
        p0[j] += dt * p1[j]
        p[j][0] = p0[j]
    for i in range(4):
        p[i][i] += q[i]


def correct(x: Rows, p: Rows, row: int, minus: int | None, z: Sequence[float], r: float) -> None:
    """Correct with the measurement z = x[row] - x[minus] (x[row] where `minus` is None) + noise of variance `r`, in place:
    K = P h / s with s = h P h + r; x' = x + K (z - h x); P' = P - K (P h)^T."""
    if minus is None:
        ph = [p_i[row] for p_i in p]
        s = ph[row] + r
        innovation = [z[axis] - x[row][axis] for axis in range(3)]
    else:
        ph = [p_i[row] - p_i[minus] for p_i in p]
        s = ph[row] - ph[minus] + r
        innovation = [z[axis] - (x[row][axis] - x[minus][axis]) for axis in range(3)]
    for i in range(4):
        gain = ph[i] / s
        x_i, p_i = x[i], p[i]
        for axis in range(3):
            x_i[axis] += gain * innovation[axis]
        for j in range(i, 4):
            p_i[j] -= gain * ph[j]
            p[j][i] = p_i[j]
