"""The plan buffer: planned frames on the run's time line, read by the tracker at any time.

The planner makes plans at 30 fps and the tracker reads at 50 Hz, so the tracker reads
by time: linear interpolation for root position and joints, slerp for the root
quaternion, velocities by finite difference over one frame period (docs/design.md, "Data
conventions"). A new plan is spliced a short look-ahead after now and cross-faded over
its first frames, so the part being executed never jumps (docs/planner.md, "Planner in the loop").

Each plan is kept as a segment on its own 30 fps grid, from its start time until the
next plan's start: the planner's frames are never resampled, and reading costs a
`bisect` over a handful of segment start times plus index arithmetic in one segment.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from controller.planner.request import FPS
from hw import g1, quat
from hw.errors import G1Error

FloatArray = NDArray[np.float64]

HISTORY_S = 2.0  # kept before the newest plan's start: context and a late splice need a little past, not the whole run
_GRID_EPS = 1e-9  # frames: times this close to a grid point count as on it (float rounding of start + k / fps)
_ROOT_POS = g1.QPOS_ROOT_POS
_ROOT_QUAT = g1.QPOS_ROOT_QUAT
_JOINTS = g1.QPOS_JOINTS


class ReferenceBufferError(G1Error, ValueError):
    """A plan that cannot go into the buffer (wrong shape, NaN, a start time off its time line), or a read of an empty buffer."""


@dataclass(frozen=True)
class ReferenceSample:
    """The reference at `time`: the pose and its velocities, as the tracker follows them.

    `root_velocity` is in the world frame (m/s), `yaw_rate` the rate of the root's heading
    (rad/s), `joint_velocity` in the order of `g1.JOINT_NAMES` (rad/s). `held` says the
    buffer ran out: the last frame is held with zero velocity (a plan came too late, or
    only a pose was set with `reset`).
    """

    time: float
    qpos: FloatArray  # [36]
    root_velocity: FloatArray  # [3]
    yaw_rate: float
    joint_velocity: FloatArray  # [29]
    held: bool


@dataclass(frozen=True)
class _Segment:
    """One plan's frames from `start` on (frame k at start + k / fps), read until the next segment's start.

    A segment cut by a later splice keeps one frame at or after the cut so the last
    stretch before the cut still interpolates between two of its own frames.
    """

    start: float
    frames: FloatArray  # [n, 36], quaternions sign-continuous


class ReferenceBuffer:
    """Planned G1 frames on the run's time line (seconds), read by time at the tracker's rate."""

    def __init__(self, fps: float = FPS, history_s: float = HISTORY_S) -> None:
        if not (math.isfinite(fps) and fps > 0):
            raise ReferenceBufferError(f"frame rate must be a positive number of frames per second, got {fps}")
        if not (math.isfinite(history_s) and history_s >= 0):
            raise ReferenceBufferError(f"history must be a non-negative number of seconds, got {history_s}")
        self.fps = float(fps)
        self.period = 1.0 / self.fps
        self.history_s = float(history_s)
        self._segments: list[_Segment] = []
        self._starts: list[float] = []  # segment start times, for bisect

    # -- writing -------------------------------------------------------------------------

    def reset(self, qpos: ArrayLike, t: float) -> None:
        """Forget every plan and hold `qpos` from `t` on (read with zero velocity at any time >= t)."""
        if np.shape(qpos) != (g1.QPOS_SIZE,):
            raise ReferenceBufferError(f"reset pose must have shape [{g1.QPOS_SIZE}] (one G1 qpos), got {list(np.shape(qpos))}")
        frame = _checked_frames(np.asarray(qpos)[None], "reset pose")
        t = _finite_time(t, "reset time")
        self._segments = [_Segment(t, _read_only(frame))]
        self._starts = [t]

    def splice(self, frames: ArrayLike, start_time: float, crossfade_frames: int = 3) -> None:
        """Put a new plan (frame 0 at `start_time`) in place of the buffer's content from `start_time` on.

        Frame k of the new plan is blended with the old content at start_time + k / fps
        with the new plan's weight k / crossfade_frames (lerp for root position and joints,
        slerp for the root quaternion) until the weight reaches 1: frame 0 is the old
        content, so the reference is continuous across the splice. The old content past
        its last frame is that frame, held (a plan may start after the buffer ran out).
        A splice into an empty buffer takes the plan as it is.
        """
        new = _checked_frames(frames, "plan")
        start_time = _finite_time(start_time, "plan start time")
        if crossfade_frames < 0:
            raise ReferenceBufferError(f"crossfade_frames must be >= 0, got {crossfade_frames}")
        if self._segments:
            first, end = self.start_time, self.end_time
            if start_time < first - _GRID_EPS * self.period:
                raise ReferenceBufferError(
                    f"plan start time {start_time:.4f} s is before the buffer's first frame at {first:.4f} s: "
                    "that part of the run is no longer held; start the plan later"
                )
            if start_time > end + self.period * (1 + _GRID_EPS):
                self._hold_until(start_time)
            new = self._crossfaded(new, start_time, crossfade_frames)
            self._cut(start_time)
        self._segments.append(_Segment(start_time, _read_only(new)))
        self._starts.append(start_time)
        self._drop_history(start_time - self.history_s)

    def move(self, transform: Callable[[FloatArray], FloatArray]) -> None:
        """Apply `transform` (frames [n, 36] -> frames) to everything held, e.g. a rigid move of the whole plan
        onto the robot: the buffer stays continuous, so the next context read from it is too."""
        self._require_content()
        self._segments = [
            _Segment(seg.start, _read_only(_checked_frames(transform(seg.frames.copy()), "moved plan"))) for seg in self._segments
        ]

    def _hold_until(self, t: float) -> None:
        """Fill the time up to `t` with the last frame held: what the tracker has been reading there anyway
        (a plan that starts after the buffer ran out, e.g. the first plan after a reset or after failures)."""
        last = self._qpos_at(self.end_time)
        gap_start = self.end_time + self.period
        count = max(math.ceil((t - gap_start) * self.fps - _GRID_EPS), 1)
        self._segments.append(_Segment(gap_start, _read_only(np.tile(last, (count, 1)))))
        self._starts.append(gap_start)

    def _crossfaded(self, new: FloatArray, start_time: float, crossfade_frames: int) -> FloatArray:
        """The new plan, sign-aligned with the old content and blended with it over its first frames."""
        old_at_start = self._qpos_at(start_time)
        if float(np.dot(new[0, _ROOT_QUAT], old_at_start[_ROOT_QUAT])) < 0:
            new[:, _ROOT_QUAT] *= -1.0
        blend = min(crossfade_frames, len(new))
        if blend == 0:
            return new
        old = np.array([self._qpos_at(start_time + k * self.period) for k in range(blend)])
        weight = np.arange(blend, dtype=np.float64) / crossfade_frames
        head = new[:blend]
        head[:, _ROOT_POS] = old[:, _ROOT_POS] + weight[:, None] * (head[:, _ROOT_POS] - old[:, _ROOT_POS])
        head[:, _JOINTS] = old[:, _JOINTS] + weight[:, None] * (head[:, _JOINTS] - old[:, _JOINTS])
        head[:, _ROOT_QUAT] = quat.slerp(old[:, _ROOT_QUAT], head[:, _ROOT_QUAT], weight)
        if len(new) > 1:
            new[:, _ROOT_QUAT] = quat.continuous(new[:, _ROOT_QUAT], axis=0)
        return new

    def _cut(self, start_time: float) -> None:
        """Drop the content from `start_time` on, keeping one frame at or after it for interpolation."""
        keep = bisect_right(self._starts, start_time - _GRID_EPS * self.period)
        del self._segments[keep:], self._starts[keep:]
        if self._segments:
            last = self._segments[-1]
            before = math.ceil((start_time - last.start) * self.fps - _GRID_EPS)  # frames strictly before the cut
            if before + 1 < len(last.frames):
                self._segments[-1] = _Segment(last.start, _read_only(last.frames[: before + 1].copy()))

    def _drop_history(self, cutoff: float) -> None:
        """Forget what lies wholly before `cutoff`, keeping one frame at or before it, so memory stays bounded."""
        while len(self._segments) > 1 and self._starts[1] <= cutoff:
            del self._segments[0], self._starts[0]
        first = self._segments[0]
        drop = min(math.floor((cutoff - first.start) * self.fps + _GRID_EPS), len(first.frames) - 1)
        if drop > 0:
            start = first.start + drop * self.period
            self._segments[0] = _Segment(start, _read_only(first.frames[drop:].copy()))
            self._starts[0] = start

    # -- reading -------------------------------------------------------------------------

    @property
    def start_time(self) -> float:
        """Time of the first frame held."""
        self._require_content()
        return self._starts[0]

    @property
    def end_time(self) -> float:
        """Time of the last frame planned; after it the buffer holds that frame."""
        self._require_content()
        last = self._segments[-1]
        return last.start + (len(last.frames) - 1) * self.period

    def remaining(self, t: float) -> float:
        """Seconds of plan left after `t` (0 once the buffer is holding its last frame)."""
        return max(0.0, self.end_time - t)

    def __len__(self) -> int:
        """Frames on the time line (a cut segment's extra frame kept for interpolation is not counted)."""
        count = 0
        for segment, next_start in zip(self._segments, [*self._starts[1:], math.inf], strict=True):
            if math.isinf(next_start):
                count += len(segment.frames)
            else:
                count += min(len(segment.frames), math.ceil((next_start - segment.start) * self.fps - _GRID_EPS))
        return count

    def sample(self, t: float) -> ReferenceSample:
        """The reference at `t`: interpolated pose and velocities by finite difference over one frame period.

        Centred on `t` where the buffer allows, one-sided near its ends; before the first
        frame it reads the first frame and after the last the last frame, with zero velocity.
        """
        self._require_content()
        if not math.isfinite(t):
            raise ReferenceBufferError(f"the reference was read at time {t}: read it at a finite time in seconds")
        first, end = self._starts[0], self.end_time
        qpos = self._qpos_at(t)
        if t < first or t > end or end - first < _GRID_EPS * self.period:
            return ReferenceSample(t, qpos, np.zeros(3), 0.0, np.zeros(g1.NUM_JOINTS), held=t > end)
        a = max(t - 0.5 * self.period, first)
        b = min(a + self.period, end)
        a = max(b - self.period, first)
        before, after = self._qpos_at(a), self._qpos_at(b)
        scale = 1.0 / (b - a)
        delta = (after - before) * scale
        yaw_rate = ((_heading(after) - _heading(before) + math.pi) % math.tau - math.pi) * scale
        return ReferenceSample(t, qpos, delta[_ROOT_POS], yaw_rate, delta[_JOINTS], held=False)

    def context(self, t: float, frames: int = 4) -> FloatArray:
        """The frames at t - (frames - 1) / fps, ..., t [frames, 36], sign-continuous: the planner's context."""
        self._require_content()
        if frames < 1:
            raise ReferenceBufferError(f"context needs at least one frame, got {frames}")
        out = np.array([self._qpos_at(t - (frames - 1 - k) * self.period) for k in range(frames)])
        if frames > 1:
            out[:, _ROOT_QUAT] = quat.continuous(out[:, _ROOT_QUAT], axis=0)
        return out

    def _qpos_at(self, t: float) -> FloatArray:
        """The interpolated frame at `t` (first frame before the buffer, last frame after it)."""
        index = bisect_right(self._starts, t) - 1
        if index < 0:
            return self._segments[0].frames[0].copy()
        segment = self._segments[index]
        frames = segment.frames
        position = (t - segment.start) * self.fps
        i = math.floor(position + _GRID_EPS)
        if i >= len(frames) - 1:
            return frames[-1].copy()
        alpha = max(position - i, 0.0)
        lo, hi = frames[i], frames[i + 1]
        out = lo + alpha * (hi - lo)
        out[_ROOT_QUAT] = _slerp_one(lo[_ROOT_QUAT].tolist(), hi[_ROOT_QUAT].tolist(), alpha)
        return out

    def _require_content(self) -> None:
        if not self._segments:
            raise ReferenceBufferError("the reference buffer is empty: reset it to a pose or splice a plan first")


def _slerp_one(a: list[float], b: list[float], alpha: float) -> tuple[float, float, float, float]:
    """Slerp of one pair of unit quaternions on Python floats: the per-tick path, where numpy's overhead dominates."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    dot = aw * bw + ax * bx + ay * by + az * bz
    if dot < 0:
        bw, bx, by, bz, dot = -bw, -bx, -by, -bz, -dot
    if dot > 1.0 - 1e-12:
        wa, wb = 1.0 - alpha, alpha  # nearly equal: linear interpolation is exact to first order
    else:
        theta = math.acos(min(dot, 1.0))
        sin_theta = math.sin(theta)
        wa, wb = math.sin((1.0 - alpha) * theta) / sin_theta, math.sin(alpha * theta) / sin_theta
    w, x, y, z = wa * aw + wb * bw, wa * ax + wb * bx, wa * ay + wb * by, wa * az + wb * bz
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    return w / norm, x / norm, y / norm, z / norm


def _heading(qpos: FloatArray) -> float:
    w, x, y, z = qpos[_ROOT_QUAT].tolist()
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _checked_frames(frames: ArrayLike, what: str) -> FloatArray:
    """`frames` as a fresh float64 [N, 36] array with unit, sign-continuous quaternions, or the error naming the problem."""
    try:
        array = np.array(frames, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ReferenceBufferError(f"{what} is not numeric: {exc}") from exc
    if array.ndim != 2 or array.shape[1] != g1.QPOS_SIZE or len(array) == 0:
        raise ReferenceBufferError(f"{what} must have shape [N, {g1.QPOS_SIZE}] with N >= 1 (G1 qpos frames), got {list(array.shape)}")
    bad = ~np.isfinite(array).all(axis=1)
    if bad.any():
        raise ReferenceBufferError(
            f"{what} holds NaN or infinite values in frame(s) {np.flatnonzero(bad).tolist()[:10]}; send finite frames"
        )
    norms = np.linalg.norm(array[:, _ROOT_QUAT], axis=1)
    if (norms < 1e-6).any():
        raise ReferenceBufferError(f"{what} has a zero root quaternion in frame(s) {np.flatnonzero(norms < 1e-6).tolist()[:10]}")
    array[:, _ROOT_QUAT] /= norms[:, None]
    if len(array) > 1:  # quat.continuous needs two frames to compare
        array[:, _ROOT_QUAT] = quat.continuous(array[:, _ROOT_QUAT], axis=0)
    return array


def _finite_time(t: float, what: str) -> float:
    t = float(t)
    if not math.isfinite(t):
        raise ReferenceBufferError(f"{what} must be a finite number of seconds, got {t}")
    return t


def _read_only(array: FloatArray) -> FloatArray:
    array.flags.writeable = False
    return array
