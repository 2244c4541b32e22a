"""Plan requests and plans: the planner contract (docs/planner.md) as typed values.

A request is checked once, here, so every planner (the learned one, the baselines, a
planner exported elsewhere) sees the same valid input. Frames are G1 `qpos` at 30 fps:
root position xyz, root quaternion w,x,y,z, 29 joint angles in the standard order.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from controller.planner.plausibility import beyond_limits, out_of_reach
from hw import g1, quat
from hw.errors import G1Error

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

FPS = 30.0
QPOS_DIM = g1.QPOS_SIZE
QVEL_DIM = g1.QVEL_SIZE
CONTEXT_FRAMES = 4
MIN_LENGTH, MAX_LENGTH, LENGTH_STEP = 24, 64, 4
ALLOWED_LENGTHS = tuple(range(MIN_LENGTH, MAX_LENGTH + 1, LENGTH_STEP))
MODES = ("inbetween",)  # command-driven modes (idle, walk, ...) arrive with the replanning loop
TEXT_ENCODER = "all-MiniLM-L6-v2"  # the sentence encoder whose embeddings fill the text slot (controller.text.encoder)
TEXT_EMBEDDING_DIM = 384  # its output size (controller.text.encoder.ENCODER_DIM)


# A keyframe joint this far outside the G1's limits is refused. Not zero: poses stored as float32 (datasets, recordings)
# put a joint at its limit up to a few 1e-7 rad beyond it (one value in the G1 Moves capture).
KEYFRAME_LIMIT_TOLERANCE_RAD = 1e-4
_QPOS_COLUMNS = ("root x", "root y", "root z", *(f"root quaternion {c}" for c in "wxyz"), *g1.JOINT_NAMES)  # what each qpos value is


class PlanRequestError(G1Error, ValueError):
    """A plan request that no planner can serve: wrong shapes, NaN, unknown mode, impossible length, a keyframe beyond the limits."""


@dataclass(frozen=True)
class Keyframe:
    """A pose constraint at plan frame `frame` (0 is the first frame after the context).

    `joints` marks which of the 29 joint angles of `qpos` are constrained; `root` constrains
    the root's horizontal position and heading, `root_height` its height and tilt. The
    defaults constrain the whole pose. `velocity` optionally gives the pose's velocity at that
    frame (MuJoCo `qvel` layout [35]: root linear velocity in the world, angular velocity in
    the body frame, joint velocities; per second, as `controller.bench.baselines.finite_velocity`
    builds it): the plan then arrives (and leaves) with it, on the channels the keyframe constrains.
    """

    frame: int
    qpos: FloatArray
    joints: BoolArray = field(default_factory=lambda: np.ones(g1.NUM_JOINTS, dtype=bool))
    root: bool = True
    root_height: bool = True
    velocity: FloatArray | None = None


@dataclass(frozen=True)
class PlanRequest:
    """What the planner is asked: continue `context` for one of `lengths` frames, meeting the keyframes.

    A target root position and heading at the last frame is a keyframe with `root=True` and
    no joints; `target_root` builds one.
    """

    context: FloatArray  # [4, 36], oldest first
    keyframes: tuple[Keyframe, ...] = ()
    lengths: tuple[int, ...] = (44,)
    mode: str = "inbetween"
    text_embedding: FloatArray | None = None  # [384] sentence embedding of a caption (TEXT_ENCODER), or no text
    seed: int = 0

    def validated(self) -> PlanRequest:
        """The same request with arrays as float64, or PlanRequestError naming what is wrong."""
        context = _finite_array(self.context, (CONTEXT_FRAMES, QPOS_DIM), "context")
        if self.mode not in MODES:
            raise PlanRequestError(f"unknown plan mode '{self.mode}'; valid modes: {', '.join(MODES)}")
        bad = [n for n in self.lengths if n not in ALLOWED_LENGTHS]
        if not self.lengths or bad:
            raise PlanRequestError(
                f"plan lengths {list(self.lengths)} are not allowed: use multiples of {LENGTH_STEP} from {MIN_LENGTH} to {MAX_LENGTH}"
            )
        longest = max(self.lengths)
        keyframes = []
        for k in self.keyframes:
            if not 0 <= k.frame < longest:
                raise PlanRequestError(f"keyframe at frame {k.frame} is outside a plan of at most {longest} frames")
            joints = np.asarray(k.joints, dtype=bool)
            if joints.shape != (g1.NUM_JOINTS,):
                raise PlanRequestError(f"keyframe joint mask must have {g1.NUM_JOINTS} entries, got shape {joints.shape}")
            qpos = _keyframe_qpos(k.qpos, k.frame, joints)
            velocity = None if k.velocity is None else _finite_array(k.velocity, (QVEL_DIM,), f"keyframe {k.frame} velocity")
            keyframes.append(Keyframe(k.frame, qpos, joints, k.root, k.root_height, velocity))
        frames = [k.frame for k in keyframes]
        if len(set(frames)) != len(frames):
            raise PlanRequestError(f"two keyframes at the same frame: {sorted(frames)}; merge them into one")
        text = None if self.text_embedding is None else _finite_array(self.text_embedding, (TEXT_EMBEDDING_DIM,), "text embedding")
        return PlanRequest(context, tuple(sorted(keyframes, key=lambda k: k.frame)), tuple(self.lengths), self.mode, text, int(self.seed))

    def unreachable(self) -> str | None:
        """Why the first keyframe out of reach cannot be met at a speed the motion data shows; None when all can."""
        for key in self.keyframes:
            if key.root:
                why = out_of_reach(self.context[-1], key.qpos[:2], key.frame, FPS, MAX_LENGTH)
                if why is not None:
                    return why
        return None

    def plan_length(self) -> int:
        """The shortest allowed length that reaches past the last keyframe."""
        last = max((k.frame for k in self.keyframes), default=-1)
        return min((n for n in self.lengths if n > last), default=max(self.lengths))


def target_root(frame: int, x: float, y: float, heading: float) -> Keyframe:
    """A keyframe that constrains only the root's horizontal position and heading (rad, about z)."""
    qpos = np.zeros(QPOS_DIM)
    qpos[g1.QPOS_ROOT_POS] = (x, y, g1.STANDING_PELVIS_HEIGHT)
    qpos[g1.QPOS_ROOT_QUAT] = quat.from_yaw(heading)
    return Keyframe(frame, qpos, joints=np.zeros(g1.NUM_JOINTS, dtype=bool), root=True, root_height=False)


@dataclass(frozen=True)
class Plan:
    """The planner's answer: `qpos` [N, 36] at 30 fps, foot contacts [N, 2] (left, right), and its latency.

    `unreachable` says why a keyframe's root is further than the plan can carry it at a speed the motion data shows
    (`plausibility.out_of_reach`); the plan still meets the keyframe, by a burst of speed nothing can follow. None: all
    keyframes are within reach.
    """

    qpos: FloatArray
    contacts: BoolArray
    latency_ms: float
    unreachable: str | None = None

    @property
    def length(self) -> int:
        return len(self.qpos)


def _keyframe_qpos(value: object, frame: int, joints: BoolArray) -> FloatArray:
    """The keyframe's qpos as float64, or PlanRequestError naming the frame and the first bad value: not finite, or a
    constrained joint outside the G1's limits."""
    qpos = _numeric(value, (QPOS_DIM,), f"keyframe {frame} qpos")
    bad = np.flatnonzero(~np.isfinite(qpos))
    if len(bad):
        raise PlanRequestError(f"keyframe at frame {frame}: {_QPOS_COLUMNS[bad[0]]} is {qpos[bad[0]]}; send finite values")
    outside = np.flatnonzero(joints & beyond_limits(qpos[g1.QPOS_JOINTS], KEYFRAME_LIMIT_TOLERANCE_RAD))
    if len(outside):
        joint = g1.G1_JOINTS[outside[0]]
        lower, upper = joint.position_limits
        raise PlanRequestError(
            f"keyframe at frame {frame}: {joint.name} is {qpos[g1.QPOS_JOINTS][outside[0]]:.4f} rad, outside the G1's limits "
            f"[{lower}, {upper}] (hw/g1.py); keep keyframe joints inside them"
        )
    return qpos


def _numeric(value: object, shape: tuple[int, ...], what: str) -> FloatArray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise PlanRequestError(f"{what} is not numeric: {exc}") from exc
    if array.shape != shape:
        raise PlanRequestError(f"{what} must have shape {list(shape)}, got {list(array.shape)}")
    return array


def _finite_array(value: object, shape: tuple[int, ...], what: str) -> FloatArray:
    array = _numeric(value, shape, what)
    if not np.isfinite(array).all():
        raise PlanRequestError(f"{what} holds NaN or infinite values; send finite frames")
    return array
