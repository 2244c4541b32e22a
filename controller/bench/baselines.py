"""Classical in-betweening baselines: linear interpolation, cubic Hermite, zero velocity.

Each fills the `length` frames between a context (the last 4 frames before the gap, G1
`qpos` [4, 36]) and a target frame [36], and returns them [length, 36]. Time runs in
frames of 30 fps: the context's last frame sits at s = 0, the transition at s = 1 .. L
and the target at s = L + 1. Root quaternions are unit and sign-continuous with the
context's last frame. Joint angles are not clamped to their limits.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from controller.planner.request import CONTEXT_FRAMES, FPS, QPOS_DIM, FloatArray, PlanRequestError
from hw import g1, quat

QVEL_DIM = g1.QVEL_SIZE  # root linear velocity (world), root angular velocity (body), joint velocities
POS, ROT, JOINTS = g1.QPOS_ROOT_POS, g1.QPOS_ROOT_QUAT, g1.QPOS_JOINTS


def interp(context: ArrayLike, target: ArrayLike, length: int) -> FloatArray:
    """Linear interpolation of root position and joint angles, slerp of the root rotation."""
    start, end = _checked(context, target, length)
    u = np.arange(1, length + 1, dtype=np.float64) / (length + 1)
    out = start + u[:, None] * (end - start)
    out[:, ROT] = quat.slerp(start[ROT], end[ROT], u)
    return _sign_continuous(start, out)


def zerovel(context: ArrayLike, target: ArrayLike, length: int) -> FloatArray:
    """Hold the context's last frame for the whole transition (the target is ignored)."""
    start, _ = _checked(context, target, length)
    return np.tile(start, (length, 1))


def hermite(context: ArrayLike, target: ArrayLike, length: int, target_velocity: ArrayLike) -> FloatArray:
    """Cubic Hermite from the context's last frame to the target, matching velocities at both ends.

    The start tangent is the finite difference of the context's last two frames. The end
    tangent is `target_velocity` [35], MuJoCo `qvel` layout at the target: root linear
    velocity (m/s, world frame), root angular velocity (rad/s, body frame), joint velocities
    (rad/s); `finite_velocity(target, next_frame)` builds it. In the benchmark it comes from
    the ground-truth frame after the target, which the window includes for this purpose: the
    baseline is thus told the true arrival velocity, an advantage no other method gets.

    Root position and joints are cubic per channel. The root rotation is q0 * exp(h(s)),
    with h a cubic Hermite in the rotation-vector space of the start frame q0: h(0) = 0,
    h(S) = log(q0^-1 q_target), and tangents mapped through the inverse right Jacobian of
    SO(3), so that the body angular velocity equals the context's at the start and the
    target's at the end exactly. It reproduces constant angular velocity about a fixed axis.
    """
    frames = np.asarray(context, dtype=np.float64)
    start, end = _checked(frames, target, length)
    velocity = np.asarray(target_velocity, dtype=np.float64)
    if velocity.shape != (QVEL_DIM,) or not np.isfinite(velocity).all():
        raise PlanRequestError(f"target velocity must be [{QVEL_DIM}] finite values (MuJoCo qvel layout), got shape {list(velocity.shape)}")
    span = float(length + 1)
    s = np.arange(1, length + 1, dtype=np.float64)[:, None]
    h00, h10, h01, h11 = _basis(s / span)

    m0 = finite_velocity(frames[-2], start, fps=1.0)  # per frame
    m1 = velocity / FPS
    out = np.empty((length, QPOS_DIM))
    lin = np.r_[POS, JOINTS]  # what is interpolated per channel, in qpos and in qvel
    vlin = np.r_[g1.QVEL_ROOT_LIN, g1.QVEL_JOINTS]
    out[:, lin] = h00 * start[lin] + h10 * span * m0[vlin] + h01 * end[lin] + h11 * span * m1[vlin]

    q0 = quat.normalize(start[ROT])
    chord = quat.log(quat.multiply(quat.conjugate(q0), end[ROT]))
    w0 = m0[g1.QVEL_ROOT_ANG]  # h'(0) = omega_0: the right Jacobian is the identity at 0
    w1 = _inverse_right_jacobian(chord) @ m1[g1.QVEL_ROOT_ANG]
    h = h10 * span * w0 + h01 * chord + h11 * span * w1
    out[:, ROT] = quat.normalize(quat.multiply(q0, quat.exp(h)))
    return _sign_continuous(start, out)


def finite_velocity(frame: ArrayLike, next_frame: ArrayLike, fps: float = FPS) -> FloatArray:
    """Velocity [35] (MuJoCo `qvel` layout) that moves `frame` to `next_frame` in 1/fps s, like mj_differentiatePos."""
    a, b = np.asarray(frame, dtype=np.float64), np.asarray(next_frame, dtype=np.float64)
    rel = quat.multiply(quat.conjugate(quat.normalize(a[ROT])), quat.normalize(b[ROT]))
    return np.concatenate((b[POS] - a[POS], quat.log(rel), b[JOINTS] - a[JOINTS])) * fps


def _basis(u: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    u2, u3 = u * u, u * u * u
    return 2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2


def _inverse_right_jacobian(phi: FloatArray) -> FloatArray:
    """J_r^-1(phi): maps a body angular velocity at exp(phi) to the rate of the rotation vector phi."""
    theta = float(np.linalg.norm(phi))
    skew = np.array([[0.0, -phi[2], phi[1]], [phi[2], 0.0, -phi[0]], [-phi[1], phi[0], 0.0]])
    if theta < 1e-6:
        coef = 1.0 / 12.0
    elif np.pi - theta < 1e-6:  # the rotation vector is ill-defined at pi: fall back to the small-angle map
        coef = 0.0
    else:
        coef = 1.0 / theta**2 - (1.0 + np.cos(theta)) / (2.0 * theta * np.sin(theta))
    return np.eye(3) + 0.5 * skew + coef * (skew @ skew)


def _checked(context: ArrayLike, target: ArrayLike, length: int) -> tuple[FloatArray, FloatArray]:
    frames = np.asarray(context, dtype=np.float64)
    goal = np.asarray(target, dtype=np.float64)
    if frames.shape != (CONTEXT_FRAMES, QPOS_DIM) or goal.shape != (QPOS_DIM,):
        raise PlanRequestError(
            f"baselines take a context [{CONTEXT_FRAMES}, {QPOS_DIM}] and a target [{QPOS_DIM}], "
            f"got {list(frames.shape)} and {list(goal.shape)}"
        )
    if not (np.isfinite(frames).all() and np.isfinite(goal).all()):
        raise PlanRequestError("context or target holds NaN or infinite values")
    if int(length) < 1:
        raise PlanRequestError(f"transition length must be at least 1 frame, got {length}")
    start = frames[-1].copy()
    start[ROT] = quat.normalize(start[ROT])
    goal = goal.copy()
    goal[ROT] = quat.normalize(goal[ROT])
    return start, goal


def _sign_continuous(start: FloatArray, frames: FloatArray) -> FloatArray:
    rot = quat.continuous(np.concatenate((start[None, ROT], frames[:, ROT])), axis=0)
    frames[:, ROT] = rot[1:]
    return frames
