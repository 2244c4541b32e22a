"""The planner's motion representation: G1 `qpos` <-> canonical channels, and the anchor curve.

Channels, per frame (36): root x, y, z; heading (unwrapped yaw, rad); tilt (the rotation
vector of the root orientation with its heading removed, 3); 29 joint angles. They are
expressed in the frame of the last context frame: its root at the origin, facing +x. The
model is thus invariant to where and which way the robot stands, and every channel can be
interpolated linearly (unlike quaternions).

The anchor curve passes exactly through every constraint (the context's last frame and
each keyframe channel) and starts with the context's velocity; the network adds a residual
that a window forces to zero at the constraints. Constraints are met by construction,
whatever the sample. All functions are vectorized over leading batch dimensions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from controller.planner.request import FPS
from hw import g1, quat

FloatArray = NDArray[np.float64]

ROOT_XY = slice(0, 2)
ROOT_Z = 2
HEADING = 3
TILT = slice(4, 7)
JOINTS = g1.QPOS_JOINTS  # the joint angles keep their qpos columns
NUM_CHANNELS = g1.QPOS_SIZE
RAMP_FRAMES = 4  # the residual window rises from 0 to 1 over this many frames away from a constraint


# ---- planar helpers --------------------------------------------------------------------


def rotate_xy(xy: FloatArray, yaw: FloatArray) -> FloatArray:
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    x, y = xy[..., :1], xy[..., 1:2]
    return np.concatenate((c * x - s * y, s * x + c * y), axis=-1)


# ---- qpos <-> channels ---------------------------------------------------------------------


def frame_origin(qpos: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The canonical frame of `qpos` [..., 36]: its root's horizontal position and heading."""
    return qpos[..., :2], quat.heading(qpos[..., g1.QPOS_ROOT_QUAT])


def to_channels(qpos: FloatArray, origin_xy: FloatArray, origin_yaw: FloatArray) -> FloatArray:
    """Frames [..., T, 36] -> channels [..., T, 36] in the frame (origin_xy [..., 2], origin_yaw [...])."""
    rotation = qpos[..., g1.QPOS_ROOT_QUAT]
    heading = quat.heading(rotation)
    tilt = quat.log(quat.multiply(quat.from_yaw(-heading), rotation))
    relative = heading - np.asarray(origin_yaw)[..., None]
    if relative.shape[-1] > 1:  # frames one by one (a request's context and keyframes) have nothing to unwrap
        relative = np.unwrap(relative, axis=-1)
    relative = relative - 2 * np.pi * np.round(relative[..., -1:] / (2 * np.pi))  # the last frame's heading in (-pi, pi]
    xy = rotate_xy(qpos[..., :2] - np.asarray(origin_xy)[..., None, :], -np.asarray(origin_yaw)[..., None])
    return np.concatenate((xy, qpos[..., 2:3], relative[..., None], tilt, qpos[..., g1.QPOS_JOINTS]), axis=-1)


def from_channels(channels: FloatArray, origin_xy: FloatArray, origin_yaw: FloatArray) -> FloatArray:
    """Inverse of `to_channels`: unit quaternions, sign-continuous over time."""
    yaw = channels[..., HEADING] + np.asarray(origin_yaw)[..., None]
    rotation = quat.continuous(quat.normalize(quat.multiply(quat.from_yaw(yaw), quat.exp(channels[..., TILT]))))
    xy = rotate_xy(channels[..., ROOT_XY], np.asarray(origin_yaw)[..., None]) + np.asarray(origin_xy)[..., None, :]
    return np.concatenate((xy, channels[..., ROOT_Z : ROOT_Z + 1], rotation, channels[..., JOINTS]), axis=-1)


# ---- anchors -------------------------------------------------------------------------------


def anchor_curve(
    context: FloatArray,
    values: FloatArray,
    mask: NDArray[np.bool_],
    velocities: FloatArray | None = None,
    velocity_mask: NDArray[np.bool_] | None = None,
    fade_frames: float | None = None,
    fade_root_xy: bool = True,
    fade_delay: float = 0.0,
) -> tuple[FloatArray, FloatArray]:
    """The curve the residual is added to, and the residual's window.

    context [..., 4, C] channels; values/mask [..., F, C]: constraint values at plan frames
    0..F-1 where mask is set; velocities/velocity_mask [..., F, C]: optional channel
    velocities (per frame) at constrained frames. Between two constraints of a channel the
    curve is a cubic Hermite: it leaves the context's last frame with the context's
    velocity, and a constraint with its given velocity; where no velocity is given it
    takes the chord's (so between keyframes without velocities it is linear). With
    `fade_frames`, what a velocity adds to the chord's fades as exp(-frames away / fade_frames):
    matched at its end, it no longer carries a dance's momentary velocity across a long gap
    (capture validation, MODEL_CARD.md); None keeps it over the whole segment. With
    `fade_root_xy` False the root's horizontal velocity never fades: it is the body's momentum,
    which a second of motion carries, where a dance's joints, heading and height turn within a
    beat. The runtime keeps it only where a keyframe carries its velocity: then both ends of the
    motion are known (held-out capture); in the loop a command may have changed since the
    context, and momentum kept there made the root's path worse (docs/planner.md). With
    `fade_delay`, a velocity is carried whole for that many frames from its end before it
    fades: over a gap no longer than that the curve is the plain cubic Hermite, which a short
    gap of capture follows better than a faded one (the runtime uses it where keyframes carry
    velocities). After the
    last constraint it holds, except a never-constrained root position or heading, which
    keeps the context's velocity. Returns (curve [..., F, C], window [..., F, C] in [0, 1]).
    """
    frames = values.shape[-2]
    t = np.arange(frames, dtype=np.float64)[:, None]  # [F, 1]
    start, velocity = context[..., -1:, :], context[..., -1:, :] - context[..., -2:-1, :]  # [..., 1, C]
    big = float(frames + 1)
    prev_t = np.maximum.accumulate(np.where(mask, t, -1.0), axis=-2)  # -1: the context's last frame
    next_t = np.minimum.accumulate(np.where(mask, t, big)[..., ::-1, :], axis=-2)[..., ::-1, :]
    has_next = next_t < big
    prev_v = _take_at(values, prev_t, start)
    next_v = _take_at(values, np.where(has_next, next_t, 0.0), start)
    span = np.maximum(next_t - prev_t, 1.0)
    u = (t - prev_t) / span
    chord = (next_v - prev_v) / span
    # What each end's velocity adds to the chord's slope (zero where none is given: the segment is linear there).
    extra0 = np.where(prev_t < 0, velocity - chord, 0.0)
    extra1: FloatArray | float = 0.0
    if velocities is not None and velocity_mask is not None and velocity_mask.any():
        given = velocity_mask & mask
        at_prev = _take_at(np.where(given, velocities, np.nan), prev_t, velocity)
        at_next = _take_at(np.where(given, velocities, np.nan), np.where(has_next, next_t, 0.0), velocity)
        extra0 = np.where(np.isnan(at_prev), 0.0, at_prev - chord)
        extra1 = np.where(np.isnan(at_next), 0.0, at_next - chord)
    if fade_frames is not None:
        fading = np.ones(values.shape[-1], dtype=bool)
        fading[ROOT_XY] = fade_root_xy
        extra0 = np.where(fading, extra0 * np.exp(-np.maximum(t - prev_t - fade_delay, 0.0) / fade_frames), extra0)
        if not isinstance(extra1, float):  # no end velocity given: nothing to fade
            extra1 = np.where(fading, extra1 * np.exp(-np.maximum(next_t - t - fade_delay, 0.0) / fade_frames), extra1)
    # Cubic Hermite from (p0, slope0) to (p1, slope1) over `span` frames: linear plus the slopes' departures from the chord.
    inner = prev_v + u * (next_v - prev_v) + span * (u * (1.0 - u) ** 2 * extra0 + u * u * (u - 1.0) * extra1)
    drifting = np.zeros(values.shape[-1], dtype=bool)
    drifting[[0, 1, HEADING]] = True
    never = ~mask.any(axis=-2, keepdims=True) & drifting
    tail = np.where(never, start + velocity * (t + 1.0), prev_v)
    curve = np.where(has_next, inner, tail)
    distance = np.minimum(t - prev_t, np.where(has_next, next_t - t, big))
    ramp = np.minimum(distance / RAMP_FRAMES, 1.0)  # distance is never negative
    return curve, ramp * ramp * (3 - 2 * ramp)


def channel_velocity(qpos: FloatArray, qvel: FloatArray, origin_xy: FloatArray, origin_yaw: FloatArray) -> FloatArray:
    """Channel velocities per frame [..., C] of frames `qpos` [..., 36] moving at `qvel` [..., 35] (MuJoCo layout, per second).

    The frame one step of 1/30 s later is integrated (root linear velocity in the world, angular
    velocity in the body frame, joints), and both go through `to_channels`: heading, tilt and
    the canonical frame are handled as for any frame.
    """
    later = np.array(qpos, dtype=np.float64, copy=True)
    step = np.asarray(qvel, dtype=np.float64) / FPS
    later[..., g1.QPOS_ROOT_POS] += step[..., g1.QVEL_ROOT_LIN]
    later[..., g1.QPOS_ROOT_QUAT] = quat.multiply(qpos[..., g1.QPOS_ROOT_QUAT], quat.exp(step[..., g1.QVEL_ROOT_ANG]))
    later[..., g1.QPOS_JOINTS] += step[..., g1.QVEL_JOINTS]
    both = to_channels(np.stack((qpos, later), axis=-2), origin_xy, origin_yaw)
    return both[..., 1, :] - both[..., 0, :]


def _take_at(values: FloatArray, frame: FloatArray, fallback: FloatArray) -> FloatArray:
    """values[..., frame, c] per (frame, channel), `fallback` where frame is -1."""
    index = np.minimum(np.maximum(frame, 0), values.shape[-2] - 1).astype(np.intp)
    # One request (the runtime): plain indexing costs a fraction of take_along_axis.
    one = values.ndim == 2
    taken = values[index, np.arange(values.shape[-1])] if one else np.take_along_axis(values, index, axis=-2)
    return np.where(frame < 0, fallback, taken)
