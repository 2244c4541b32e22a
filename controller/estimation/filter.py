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
    K = P h / s with s = h P h + r; x' = x + K (z - h x); P' = P - (P h)(P h)^T / s."""
    measured = x[row]
    if minus is None:
        ph = [p_i[row] for p_i in p]
        s = ph[row] + r
        e0, e1, e2 = z[0] - measured[0], z[1] - measured[1], z[2] - measured[2]
    else:
        base = x[minus]
        ph = [p_i[row] - p_i[minus] for p_i in p]
        s = ph[row] - ph[minus] + r
        e0, e1, e2 = z[0] - (measured[0] - base[0]), z[1] - (measured[1] - base[1]), z[2] - (measured[2] - base[2])
    inverse = 1.0 / s
    ph0, ph1, ph2, ph3 = ph
    for x_i, p_i, ph_i in zip(x, p, ph, strict=True):
        gain = ph_i * inverse
        x_i[0] += gain * e0
        x_i[1] += gain * e1
        x_i[2] += gain * e2
        # ph_i ph_j / s, multiplied in this order, is the same float as ph_j ph_i / s: P stays exactly symmetric
        p_i[0] -= ph_i * ph0 * inverse
        p_i[1] -= ph_i * ph1 * inverse
        p_i[2] -= ph_i * ph2 * inverse
        p_i[3] -= ph_i * ph3 * inverse
