"""Foot locking: keep a planted foot where it landed, by inverse kinematics of its leg.

A sampled plan places each stance foot a few centimetres differently from frame to frame;
on the robot that is foot skate. For each run of frames where the plan says a foot is in
contact, the foot's horizontal position is pinned to where the run starts (to where the
context left it, or to a keyframe's foot when the run holds one), and that leg's six joint
angles are corrected by damped least squares on the foot position. Corrections fade in and
out over a few frames at the run's ends and vanish at frames whose leg joints are
constrained, so keyframes stay exact. Pure numpy: the leg chains (link offsets, rotations,
joint axes of the G1) come from the model folder's spec, written at export from the MJCF.
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


@dataclass(frozen=True)
class LegChains:
    """Both legs from the pelvis, stacked [2, ...]: link offsets [2, 6, 3], fixed link rotations [2, 6, 3, 3],
    joint axes [2, 6, 3] with their cross-product matrices, and the sole point [2, 3] in the last link."""

    offsets: FloatArray
    rotations: FloatArray
    axes: FloatArray
    sole: FloatArray
    _skews: tuple[FloatArray, FloatArray] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        skew = _skew(self.axes)  # K and K @ K of every joint axis, for Rodrigues' formula
        object.__setattr__(self, "_skews", (skew, skew @ skew))

    @classmethod
    def from_spec(cls, legs: list[dict[str, Any]]) -> LegChains:
        def stacked(key: str) -> FloatArray:
            return np.stack([np.asarray(leg[key], dtype=np.float64) for leg in legs])

        return cls(stacked("offsets"), quat.to_matrix(stacked("quats")), stacked("axes"), stacked("sole"))

    def forward(self, root_pos: FloatArray, root_rot: FloatArray, q: FloatArray, leg: NDArray[np.intp]) -> tuple[FloatArray, ...]:
        """Sole points [K, 3], joint positions [K, 6, 3] and world joint axes [K, 6, 3] of legs `leg` [K] at angles q [K, 6]."""
        offsets, fixed, axes = self.offsets[leg], self.rotations[leg], self.axes[leg]
        skew, skew2 = (k[leg] for k in self._skews)
        sin, cos = np.sin(q)[..., None, None], np.cos(q)[..., None, None]
        turns = np.eye(3) + sin * skew + (1.0 - cos) * skew2  # Rodrigues, [K, 6, 3, 3]
        position, rotation = root_pos, root_rot
        joints, world_axes = [], []
        for i in range(6):
            position = position + (rotation @ offsets[:, i, :, None])[..., 0]
            rotation = rotation @ fixed[:, i]
            world_axes.append((rotation @ axes[:, i, :, None])[..., 0])
            joints.append(position)
            rotation = rotation @ turns[:, i]
        sole = position + (rotation @ self.sole[leg][..., None])[..., 0]
        return sole, np.stack(joints, axis=1), np.stack(world_axes, axis=1)


def lock_feet(qpos: FloatArray, contacts: BoolArray, legs: LegChains, context_last: FloatArray, fixed: BoolArray) -> FloatArray:
    """Plans [S, N, 36] with stance feet pinned; `fixed` [N, 2] marks frames whose leg joints a keyframe constrains."""
    seeds, frames = qpos.shape[:2]
    both = np.array([0, 1])
    root_rot = quat.to_matrix(qpos[..., _ROT])  # [S, N, 3, 3]
    # Every frame's and the context's soles in one pass: rows (seed, frame, leg) then the context's two legs.
    rows_q = np.concatenate((qpos[..., _LEGS_IN_QPOS].reshape(-1, 2, 6).reshape(-1, 6), context_last[_LEGS_IN_QPOS].reshape(2, 6)))
    rows_pos = np.concatenate((np.repeat(qpos[..., _POS].reshape(-1, 3), 2, axis=0), np.tile(context_last[_POS], (2, 1))))
    rows_rot = np.concatenate((np.repeat(root_rot.reshape(-1, 3, 3), 2, axis=0), np.tile(quat.to_matrix(context_last[_ROT]), (2, 1, 1))))
    rows_leg = np.concatenate((np.tile(both, seeds * frames), both))
    soles, all_joints, all_axes = legs.forward(rows_pos, rows_rot, rows_q, rows_leg)
    sole, context_sole = soles[:-2].reshape(seeds, frames, 2, 3), soles[-2:]
    target = sole.copy()
    for s in range(seeds):
        for side in (0, 1):
            for start, stop in _runs(contacts[s, :, side]):
                anchors = np.flatnonzero(fixed[start:stop, side])
                if len(anchors):
                    anchor = sole[s, start + anchors[0], side, :2]
                elif start == 0:
                    anchor = context_sole[side, :2]
                else:
                    anchor = sole[s, start, side, :2]
                target[s, start:stop, side, :2] = anchor
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
        jacobian = np.cross(axes, current[:, None, :] - joint_pos).transpose(0, 2, 1)  # [K, 3, 6]
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


def _skew(v: FloatArray) -> FloatArray:
    x, y, z = np.moveaxis(v, -1, 0)
    zero = np.zeros_like(x)
    return np.stack((np.stack((zero, -z, y), -1), np.stack((z, zero, -x), -1), np.stack((-y, x, zero), -1)), -2)
