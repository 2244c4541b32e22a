"""Unit quaternions (w, x, y, z) in pure numpy, vectorized over leading dimensions.

The convention is MuJoCo's: `q` rotates body coordinates into world coordinates, and a
free joint's angular velocity is expressed in the body frame. q and -q are the same
rotation; functions that compare or interpolate take the shorter way.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

_EPS = 1e-12


# These functions run on a planner's few dozen frames many times a plan: they take components by indexing and fill their
# output in place, where np.moveaxis and np.stack would cost more than the arithmetic (same values, bit for bit).


def _components(q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """w, x, y, z of q [..., 4], as views."""
    return q[..., 0], q[..., 1], q[..., 2], q[..., 3]


def _stacked(*parts: FloatArray) -> FloatArray:
    """`np.stack(parts, axis=-1)` of arrays that share one shape."""
    out = np.empty((*np.shape(parts[0]), len(parts)))
    for i, part in enumerate(parts):
        out[..., i] = part
    return out


def _length(v: FloatArray) -> FloatArray:
    """Euclidean length over the last axis, kept as [..., 1] (what np.linalg.norm computes, without its overhead)."""
    return np.sqrt(np.add.reduce(v * v, axis=-1, keepdims=True))


def normalize(q: ArrayLike) -> FloatArray:
    q = np.asarray(q, dtype=np.float64)
    return q / np.maximum(_length(q), _EPS)


def multiply(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Hamilton product a * b (apply b, then a)."""
    aw, ax, ay, az = _components(np.asarray(a, dtype=np.float64))
    bw, bx, by, bz = _components(np.asarray(b, dtype=np.float64))
    return _stacked(
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def conjugate(q: ArrayLike) -> FloatArray:
    """The inverse of a unit quaternion."""
    return np.asarray(q, dtype=np.float64) * np.array([1.0, -1.0, -1.0, -1.0])


def rotate(q: ArrayLike, v: ArrayLike) -> FloatArray:
    """Rotate vectors v [..., 3] by q [..., 4]."""
    v = np.asarray(v, dtype=np.float64)
    qv = np.concatenate((np.zeros((*v.shape[:-1], 1)), v), axis=-1)
    return multiply(multiply(q, qv), conjugate(q))[..., 1:]


def to_matrix(q: ArrayLike) -> FloatArray:
    """Rotation matrices [..., 3, 3] of q [..., 4], normalized first: body to world coordinates."""
    w, x, y, z = _components(normalize(q))
    m = np.empty((*w.shape, 3, 3))
    m[..., 0, 0], m[..., 0, 1], m[..., 0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    m[..., 1, 0], m[..., 1, 1], m[..., 1, 2] = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    m[..., 2, 0], m[..., 2, 1], m[..., 2, 2] = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    return m


def log(q: ArrayLike) -> FloatArray:
    """Rotation vector [..., 3] (axis * angle, angle in [0, pi]) of q [..., 4]."""
    q = normalize(q)
    q = np.where(q[..., :1] < 0, -q, q)
    vec = q[..., 1:]
    sin_half = _length(vec)
    angle = 2 * np.arctan2(sin_half, q[..., :1])
    scale = np.where(sin_half > 1e-9, angle / np.maximum(sin_half, _EPS), 2.0)
    return vec * scale


def exp(rotvec: ArrayLike) -> FloatArray:
    """Unit quaternion [..., 4] of a rotation vector [..., 3]."""
    rotvec = np.asarray(rotvec, dtype=np.float64)
    angle = _length(rotvec)
    scale = np.where(angle > 1e-9, np.sin(angle / 2) / np.maximum(angle, _EPS), 0.5)
    return np.concatenate((np.cos(angle / 2), rotvec * scale), axis=-1)


def from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> FloatArray:
    """Rotation by `angle` [...] (rad) about `axis` [..., 3] (any length but zero)."""
    return exp(normalize(axis) * np.asarray(angle, dtype=np.float64)[..., None])


def from_yaw(yaw: ArrayLike) -> FloatArray:
    """Rotation [..., 4] by `yaw` [...] (rad) about the world z axis: a heading with no tilt."""
    half = np.asarray(yaw, dtype=np.float64) / 2
    out = np.zeros((*half.shape, 4))
    out[..., 0], out[..., 3] = np.cos(half), np.sin(half)
    return out


def angle(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Geodesic angle (rad, in [0, pi]) between the rotations a and b (accurate near 0, unlike arccos of the dot)."""
    rel = multiply(conjugate(normalize(a)), normalize(b))
    return 2 * np.arctan2(_length(rel[..., 1:])[..., 0], np.abs(rel[..., 0]))


def slerp(a: ArrayLike, b: ArrayLike, t: ArrayLike) -> FloatArray:
    """Spherical linear interpolation from a (t=0) to b (t=1) the short way; t broadcasts against [...]."""
    a, b = normalize(a), normalize(b)
    t = np.asarray(t, dtype=np.float64)[..., None]
    dot = np.sum(a * b, axis=-1, keepdims=True)
    b = np.where(dot < 0, -b, b)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, 0.0, 1.0))
    sin_theta = np.sin(theta)
    close = sin_theta < 1e-6  # nearly equal: linear interpolation is exact to first order
    safe = np.where(close, 1.0, sin_theta)
    wa = np.where(close, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    wb = np.where(close, t, np.sin(t * theta) / safe)
    return normalize(wa * a + wb * b)


def continuous(q: ArrayLike, axis: int = -2) -> FloatArray:
    """Flip signs along `axis` (time) so that consecutive quaternions have a non-negative dot product."""
    q = np.asarray(q, dtype=np.float64)
    time_axis = axis % q.ndim
    if time_axis != q.ndim - 2:
        return np.moveaxis(continuous(np.moveaxis(q, time_axis, -2)), -2, time_axis)
    flips = np.add.reduce(q[..., 1:, :] * q[..., :-1, :], axis=-1, keepdims=True) < 0  # a flip at i changes every later frame
    sign = np.ones((*q.shape[:-1], 1))
    sign[..., 1:, :] = np.where(np.cumsum(flips, axis=-2) % 2 == 1, -1.0, 1.0)
    return q * sign


def heading(q: ArrayLike) -> FloatArray:
    """Yaw (rad, in (-pi, pi]) of the body x axis projected on the ground plane."""
    w, x, y, z = _components(np.asarray(q, dtype=np.float64))
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def heading_of(q: FloatArray) -> float:
    """`heading` of one quaternion (w, x, y, z), as a float: what a control tick needs, without numpy's cost per call."""
    w, x, y, z = q.tolist()
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def wrapped(a: float) -> float:
    """`wrap_angle` of one angle, as a float."""
    return (a + math.pi) % math.tau - math.pi


def rpy(q: ArrayLike) -> FloatArray:
    """Roll, pitch, yaw (rad) [..., 3] of q [..., 4], the z-y-x Euler angles (q = yaw * pitch * roll); pitch in [-pi/2, pi/2]."""
    w, x, y, z = _components(np.asarray(q, dtype=np.float64))
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    return _stacked(roll, pitch, heading(q))


def wrap_angle(a: ArrayLike) -> FloatArray:
    """Angles wrapped into [-pi, pi)."""
    return (np.asarray(a, dtype=np.float64) + np.pi) % (2 * np.pi) - np.pi


def rotate_inverse_one(q: FloatArray, v: FloatArray) -> FloatArray:
    """Rotate one world vector `v` [3] into the frame of one unit quaternion `q` [4] (w, x, y, z).

    The per-tick form of `rotate(conjugate(q), v)`, written on scalars: a control tick
    calls it twice, and numpy's small-array overhead would cost more than the arithmetic.
    """
    w, x, y, z = q.tolist()
    vx, vy, vz = v.tolist()
    k = 2.0 * w * w - 1.0
    dot2 = 2.0 * (x * vx + y * vy + z * vz)
    w2 = 2.0 * w
    return np.array(
        (
            vx * k - (y * vz - z * vy) * w2 + x * dot2,
            vy * k - (z * vx - x * vz) * w2 + y * dot2,
            vz * k - (x * vy - y * vx) * w2 + z * dot2,
        )
    )
