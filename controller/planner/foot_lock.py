"""Foot locking: keep a planted foot where it landed, by inverse kinematics of its leg.

A sampled plan places each stance foot a few centimetres differently from frame to frame;
on the robot that is foot skate. For each run of frames where the plan says a foot is in
contact, the foot's horizontal position is pinned where the run lands (where the context left
it, for a run from the plan's first frame), and that leg's six joint angles are corrected by
damped least squares on the foot position. Two kinds of run are treated otherwise, measured on
held-out capture (docs/planner.md):
- a run that holds a keyframe's foot (or ends within its fade of one) goes from where it lands
  to that foot in a straight line, then stays there: both ends are known, and pinning the whole
  run to either one moved the foot by the distance between them at the other (by 0.4 m in one
  frame, on a fencing lunge);
- a run whose two known ends are further apart than a planted foot slides (MOVING_FOOT_MPS) is
  a step the model took for a stance, and is left as planned.
The context's own foot speed tells a swing only where the caller passes the context's
second-to-last frame: the runtime does so where keyframes carry velocities, whose context is
motion that was measured. A run from the plan's first frame whose foot left the context faster
than a planted foot slides is then a step, left as planned. In the loop the context is the
buffer being executed, whose feet a re-anchoring moves, and gating on it there left stance feet
unpinned (walk_turn_stop's planned foot skate 0.074 -> 0.210 m/s).
Corrections fade in and out over a few frames at the run's ends and vanish at frames whose leg
joints are constrained, so keyframes stay exact. Pure numpy: the leg chains (link offsets,
rotations, joint axes of the G1) come from the model folder's spec, written at export from the
MJCF.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hw import g1, quat

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

_LEGS_IN_QPOS = g1.joint_slice(g1.LEG_JOINTS, qpos=True)  # left leg then right leg, six joints each
_LEG_COLUMNS = np.array([g1.joint_indices(leg, qpos=True) for leg in (g1.LEFT_LEG_JOINTS, g1.RIGHT_LEG_JOINTS)])  # [2, 6]
_POS, _ROT = g1.QPOS_ROOT_POS, g1.QPOS_ROOT_QUAT
FADE_FRAMES = 3
DAMPING = 0.02  # m: damped least squares keeps corrections small near a straight knee
ITERATIONS = 1
# A planted foot of retargeted capture slides at 0.09 m/s on average (bench inbetween's truth); a stance whose ends are
# further apart than this speed allows (1 cm a frame at 30 fps) is a step.
MOVING_FOOT_MPS = 0.3


@dataclass(frozen=True)
class LegChains:
    """Both legs from the pelvis, stacked [2, ...]: link offsets [2, 6, 3], fixed link rotations [2, 6, 3, 3],
    joint axes [2, 6, 3], and the sole point [2, 3] in the last link."""

    offsets: FloatArray
    rotations: FloatArray
    axes: FloatArray
    sole: FloatArray
    _turn_terms: tuple[FloatArray, FloatArray, FloatArray] = field(init=False, repr=False, compare=False)
    _offsets_and_axes: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # A link's fixed rotation F times its joint's turn by q about axis a (Rodrigues: I + sin q K + (1 - cos q) K K, K
        # the cross-product matrix of a) is F + sin q FK + (1 - cos q) FKK: one product a joint in `forward`, not two.
        skew = _skew(self.axes)
        fk = self.rotations @ skew
        object.__setattr__(self, "_turn_terms", (self.rotations, fk, fk @ skew))
        # Each link's offset and its joint's axis in the parent link, side by side [2, 6, 3, 2]: one product a joint.
        in_parent = (self.rotations @ self.axes[..., None])[..., 0]
        object.__setattr__(self, "_offsets_and_axes", np.stack((self.offsets, in_parent), axis=-1))

    @classmethod
    def from_spec(cls, legs: list[dict[str, Any]]) -> LegChains:
        def stacked(key: str) -> FloatArray:
            return np.stack([np.asarray(leg[key], dtype=np.float64) for leg in legs])

        return cls(stacked("offsets"), quat.to_matrix(stacked("quats")), stacked("axes"), stacked("sole"))

    def forward(self, root_pos: FloatArray, root_rot: FloatArray, q: FloatArray, leg: NDArray[np.intp]) -> tuple[FloatArray, ...]:
        """Sole points [K, 3], joint positions [K, 6, 3] and world joint axes [K, 6, 3] of legs `leg` [K] at angles q [K, 6]."""
        fixed, fk, fkk = (term[leg] for term in self._turn_terms)
        sin, cos = np.sin(q)[..., None, None], np.cos(q)[..., None, None]
        links = fixed + sin * fk + (1.0 - cos) * fkk  # [K, 6, 3, 3]: each link's rotation from its parent, at its angle
        offsets_and_axes = self._offsets_and_axes[leg]
        position, rotation = root_pos, root_rot
        joints, world_axes = np.empty((len(leg), 6, 3)), np.empty((len(leg), 6, 3))
        for i in range(6):
            moved = rotation @ offsets_and_axes[:, i]  # [K, 3, 2]: the offset to joint i and its axis, in the world
            position = position + moved[..., 0]
            joints[:, i], world_axes[:, i] = position, moved[..., 1]
            rotation = rotation @ links[:, i]
        sole = position + (rotation @ self.sole[leg][..., None])[..., 0]
        return sole, joints, world_axes


def sole_points(legs: LegChains, frames: FloatArray) -> FloatArray:
    """Both soles' world points [T, 2, 3] (left, right) of frames [T, 36]."""
    count = len(frames)
    root_pos = np.repeat(frames[:, _POS], 2, axis=0)
    root_rot = np.repeat(quat.to_matrix(frames[:, _ROT]), 2, axis=0)
    q = frames[:, _LEGS_IN_QPOS].reshape(count * 2, 6)
    return legs.forward(root_pos, root_rot, q, _alternate_legs(count * 2))[0].reshape(count, 2, 3)


def lock_feet(
    qpos: FloatArray, contacts: BoolArray, legs: LegChains, context_last: FloatArray, fixed: BoolArray, fps: float,
    context_before: FloatArray | None = None,
) -> FloatArray:  # fmt: skip
    """Plans [S, N, 36] with stance feet pinned; `context_last` [36] is the context's last frame, `fixed` [N, 2] marks
    frames whose leg joints a keyframe constrains, `fps` the plan's frame rate. With `context_before` [36], the frame
    before `context_last`, a run from the first frame whose foot was moving at the context's end is left as planned."""
    seeds, frames = qpos.shape[:2]
    # Every frame's soles and the context's last frame's in one pass: rows (seed, frame, leg), then the context's two legs.
    poses = np.concatenate((qpos.reshape(-1, qpos.shape[-1]), context_last[None]))
    rotations = quat.to_matrix(poses[:, _ROT])
    root_rot = rotations[:-1].reshape(seeds, frames, 3, 3)
    rows_q = poses[:, _LEGS_IN_QPOS].reshape(-1, 6)
    rows_pos, rows_rot = np.repeat(poses[:, _POS], 2, axis=0), np.repeat(rotations, 2, axis=0)
    soles, all_joints, all_axes = legs.forward(rows_pos, rows_rot, rows_q, _alternate_legs(len(rows_q)))
    sole, context_sole = soles[:-2].reshape(seeds, frames, 2, 3), soles[-2:]
    leaving = np.zeros(2, dtype=bool)  # a foot that was moving as the context ended: a run from frame 0 is a step
    if context_before is not None:
        before = sole_points(legs, context_before[None])[0]
        leaving = np.linalg.norm(context_sole[:, :2] - before[:, :2], axis=-1) * fps > MOVING_FOOT_MPS
    contacts = contacts.copy()
    target = sole.copy()
    for s in range(seeds):
        for side in (0, 1):
            for start, stop in _runs(contacts[s, :, side]):
                if start == 0 and leaving[side]:
                    contacts[s, :stop, side] = False  # left as planned: no pin, no fade
                    continue
                landed = context_sole[side, :2] if start == 0 else sole[s, start, side, :2]
                keyed = np.flatnonzero(fixed[start : stop + FADE_FRAMES, side])  # a keyframe in the run or its fade-out
                if len(keyed):
                    at = start + int(keyed[0])
                    keyed_sole = sole[s, at, side, :2]
                    if np.linalg.norm(keyed_sole - landed) * fps / max(at - start, 1) > MOVING_FOOT_MPS:
                        continue  # the keyframe puts the foot further than a planted foot slides: a step, left as planned
                    share = (np.arange(start, at + 1) - start) / max(at - start, 1)
                    target[s, start : at + 1, side, :2] = landed + share[:, None] * (keyed_sole - landed)
                    target[s, at:stop, side, :2] = keyed_sole
                else:
                    target[s, start:stop, side, :2] = landed
    weight = _fade(contacts)
    weight[:, fixed] = 0.0
    active = weight > 0  # [S, N, 2]
    if not active.any():
        return qpos.copy()
    seed_idx, frame_idx, leg_idx = np.nonzero(active)
    columns = _LEG_COLUMNS[leg_idx]  # each active row's leg joints in qpos
    start_q = qpos[seed_idx[:, None], frame_idx[:, None], columns]
    q, goal = start_q.copy(), target[active]
    base_pos, base_rot = qpos[seed_idx, frame_idx, _POS], root_rot[seed_idx, frame_idx]
    row = (seed_idx * frames + frame_idx) * 2 + leg_idx  # the first pass already holds each active row's kinematics
    current, joint_pos, axes = soles[row], all_joints[row], all_axes[row]
    for iteration in range(ITERATIONS):
        if iteration:
            current, joint_pos, axes = legs.forward(base_pos, base_rot, q, leg_idx)
        jacobian = _cross(axes, current[:, None, :] - joint_pos).transpose(0, 2, 1)  # [K, 3, 6]
        gram = jacobian @ jacobian.transpose(0, 2, 1) + DAMPING**2 * np.eye(3)
        step = np.linalg.solve(gram, (goal - current)[..., None])  # [K, 3, 1]
        q = q + (jacobian.transpose(0, 2, 1) @ step)[..., 0]
    out = qpos.copy()
    out[seed_idx[:, None], frame_idx[:, None], columns] += weight[active][:, None] * (q - start_q)
    return out


def _runs(flags: NDArray[np.bool_]) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.concatenate(([0], flags.astype(np.int8), [0]))))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def _fade(contacts: BoolArray) -> FloatArray:
    """[S, N, 2]: 1 on contact frames, falling linearly to 0 over FADE_FRAMES frames on each side of a run."""
    t = np.arange(contacts.shape[1], dtype=np.float64)[:, None]
    far = float(contacts.shape[1] + FADE_FRAMES + 1)
    last = np.maximum.accumulate(np.where(contacts, t, -far), axis=1)  # the latest contact frame at or before t
    following = np.minimum.accumulate(np.where(contacts, t, 2 * far)[:, ::-1], axis=1)[:, ::-1]  # the next one at or after t
    distance = np.minimum(t - last, following - t)
    return np.clip(1.0 - distance / (FADE_FRAMES + 1), 0.0, 1.0)


def _alternate_legs(rows: int) -> NDArray[np.intp]:
    """0, 1, 0, 1, ...: the left and the right leg of each frame."""
    return np.arange(rows) % 2


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """a x b over the last axis of same-shape arrays (np.cross costs more than the arithmetic on a plan's few rows)."""
    out = np.empty(a.shape)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _skew(v: FloatArray) -> FloatArray:
    x, y, z = np.moveaxis(v, -1, 0)
    zero = np.zeros_like(x)
    return np.stack((np.stack((zero, -z, y), -1), np.stack((z, zero, -x), -1), np.stack((-y, x, zero), -1)), -2)
