"""Random training windows: context, plan frames, and the constraints a request could carry.

Each window is cut at a random place of a random clip (see `WindowSampler` for the shares) and gets a
random plan length and a random constraint set shaped like the requests the planner will
meet: a target root (and often the full pose) at or near the last frame, sometimes partial
pose keyframes earlier (arms only, legs only, ...). Everything is numpy and batched.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from controller.planner import encoding as enc
from controller.planner import features as ft
from controller.planner.request import ALLOWED_LENGTHS, CONTEXT_FRAMES

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class WindowBatch:
    cond: FloatArray  # [B, COND_DIM]
    target: FloatArray  # [B, F, 38] residual over the anchor curve, zero beyond the length
    curve: FloatArray  # [B, F, C]
    window: FloatArray  # [B, F, C]
    truth: FloatArray  # [B, F, C] true channels
    length: NDArray[np.int64]  # [B]


class WindowSampler:
    """Draws batches from clips (`qpos` [T, 36] and `contacts` [T, 2] at 30 fps).

    Clips come in groups (one per dataset folder); each group gets an equal share of the
    windows, and within a group a clip's share follows its length. Without this, an hour of
    recorded walking would drown a quarter hour of motion capture.
    """

    def __init__(self, groups: list[list[tuple[FloatArray, FloatArray]]], min_frames: int = CONTEXT_FRAMES + ALLOWED_LENGTHS[0]) -> None:
        self.clips: list[tuple[FloatArray, FloatArray]] = []
        weights: list[FloatArray] = []
        for group in groups:
            kept = [(np.asarray(q, dtype=np.float64), np.asarray(c, dtype=np.float64)) for q, c in group if len(q) >= min_frames]
            if kept:
                sizes = np.array([len(q) - min_frames + 1 for q, _ in kept], dtype=np.float64)
                self.clips += kept
                weights.append(sizes / sizes.sum())
        if not self.clips:
            raise ValueError(f"no clip has the {min_frames} frames a training window needs")
        self._weights = np.concatenate(weights) / len(weights)

    def sample(self, rng: np.random.Generator, batch: int) -> WindowBatch:
        span = CONTEXT_FRAMES + enc.FRAMES
        qpos = np.empty((batch, span, 36))
        contacts = np.zeros((batch, enc.FRAMES, 2))
        length = np.empty(batch, dtype=np.int64)
        for b, index in enumerate(rng.choice(len(self.clips), size=batch, p=self._weights)):
            clip_q, clip_c = self.clips[index]
            fits = [n for n in ALLOWED_LENGTHS if CONTEXT_FRAMES + n <= len(clip_q)]
            n = int(rng.choice(fits))
            start = int(rng.integers(0, len(clip_q) - CONTEXT_FRAMES - n + 1))
            piece = clip_q[start : start + span]
            qpos[b, : len(piece)] = piece
            qpos[b, len(piece) :] = piece[-1]  # padding beyond the plan length is never used
            contacts[b, :n] = clip_c[start + CONTEXT_FRAMES : start + CONTEXT_FRAMES + n]
            length[b] = n
        origin_xy, origin_yaw = ft.frame_origin(qpos[:, CONTEXT_FRAMES - 1])
        channels = ft.to_channels(qpos, origin_xy, origin_yaw)
        context, truth = channels[:, :CONTEXT_FRAMES], channels[:, CONTEXT_FRAMES:]
        mask = random_constraints(rng, length)
        curve, window = ft.anchor_curve(context, truth, mask)
        cond = enc.conditioning(context, curve, mask, length)
        target = enc.residual_target(truth, contacts, curve, length)
        return WindowBatch(cond, target, curve, window, truth, length)


def random_constraints(rng: np.random.Generator, length: NDArray[np.int64]) -> NDArray[np.bool_]:
    """[B, F, C] masks: a main keyframe near the end, sometimes earlier partial keyframes."""
    mask = np.zeros((len(length), enc.FRAMES, ft.NUM_CHANNELS), dtype=bool)
    for b, n in enumerate(length):
        main = n - 1 if rng.random() < 0.4 else int(rng.integers(max(n - 10, 0), n)) if rng.random() < 0.85 else int(rng.integers(n))
        kind = rng.random()
        mask[b, main, [0, 1, ft.HEADING]] = True
        if kind < 0.65:  # the whole pose
            mask[b, main] = True
        elif kind < 0.85:  # root and some joints
            mask[b, main, ft.JOINTS] = enc.joint_group_mask(rng)
        for _ in range(rng.choice(3, p=(0.6, 0.25, 0.15))):
            frame = int(rng.integers(0, main + 1))
            mask[b, frame, ft.JOINTS] |= enc.joint_group_mask(rng)
            if rng.random() < 0.3:
                mask[b, frame, [0, 1, ft.HEADING]] = True
    return mask
