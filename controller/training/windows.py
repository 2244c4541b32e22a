"""Random training windows: context, plan frames, and the constraints a request could carry.

Each window is cut at a random place of a random clip (see `WindowSampler` for the shares) and gets a
random plan length and a random constraint set shaped like the requests the planner will
meet: a target root (and often the full pose) at or near the last frame, sometimes partial
pose keyframes earlier (arms only, legs only, ...). With a `TextTable`, it also gets the
embedding of (a paraphrase of) the caption in force over most of its plan frames, or no
text at the table's dropout rate. Everything is numpy and batched.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from controller.planner import encoding as enc
from controller.planner import features as ft
from controller.planner.request import ALLOWED_LENGTHS, CONTEXT_FRAMES, TEXT_EMBEDDING_DIM
from controller.training.captions import Captions, TextTable, caption_in_force

FloatArray = NDArray[np.float64]


class TrainClip(NamedTuple):
    """A clip as training reads it: `qpos` [T, 36], contacts [T, 2] as floats, captions by first frame."""

    qpos: FloatArray
    contacts: FloatArray
    captions: Captions = ()


@dataclass(frozen=True)
class WindowBatch:
    cond: FloatArray  # [B, COND_DIM]
    target: FloatArray  # [B, F, 38] residual over the anchor curve, zero beyond the length
    curve: FloatArray  # [B, F, C]
    window: FloatArray  # [B, F, C]
    truth: FloatArray  # [B, F, C] true channels
    length: NDArray[np.int64]  # [B]
    captions: tuple[str | None, ...] = ()  # [B] the caption in force over most of each window's plan frames
    has_text: NDArray[np.bool_] | None = None  # [B] whether the conditioning carries a text embedding


class WindowSampler:
    """Draws batches from clips (`qpos` [T, 36] and `contacts` [T, 2] at 30 fps).

    Clips come in groups (one per dataset folder); each group gets a share of the windows
    (`group_weights`, normalized; equal shares by default), and within a group a clip's share
    follows its length. Without this, an hour of recorded walking would drown a quarter hour
    of motion capture. A group is a list of `TrainClip`s or of (qpos, contacts) pairs.
    """

    def __init__(
        self,
        groups: Sequence[Sequence[TrainClip | tuple[FloatArray, FloatArray]]],
        min_frames: int = CONTEXT_FRAMES + ALLOWED_LENGTHS[0],
        group_weights: Sequence[float] | None = None,
        text: TextTable | None = None,
        free_share: float = 0.0,  # windows with no constraint at all: the context (and the text) alone decide the motion
        velocity_share: float = 0.0,  # windows whose keyframes carry their true velocity, where the clip has the frame after
        fade_frames: float | None = None,  # the anchor curve's velocity fade (features.anchor_curve)
        momentum_with_velocity: bool = False,  # windows with keyframe velocities keep the root's horizontal momentum
        velocity_fade_delay: float = 0.0,  # ... and carry their velocities whole this many frames before they fade
    ) -> None:
        if group_weights is not None and (len(group_weights) != len(groups) or min(group_weights, default=0.0) <= 0):
            raise ValueError(f"group_weights must be {len(groups)} positive numbers, one per group, got {list(group_weights)}")
        self.clips: list[TrainClip] = []
        self.text = text
        self.free_share = free_share
        self.velocity_share = velocity_share
        self.fade_frames = fade_frames
        self.momentum_with_velocity = momentum_with_velocity
        self.velocity_fade_delay = velocity_fade_delay
        weights: list[FloatArray] = []
        shares: list[float] = []
        for g, group in enumerate(groups):
            kept = [
                TrainClip(np.asarray(clip[0], dtype=np.float64), np.asarray(clip[1], dtype=np.float64), *clip[2:])
                for clip in group
                if len(clip[0]) >= min_frames
            ]
            if kept:
                sizes = np.array([len(c.qpos) - min_frames + 1 for c in kept], dtype=np.float64)
                self.clips += kept
                weights.append(sizes / sizes.sum())
                shares.append(1.0 if group_weights is None else float(group_weights[g]))
        if not self.clips:
            raise ValueError(f"no clip has the {min_frames} frames a training window needs")
        total = sum(shares)
        self._weights = np.concatenate([w * share / total for w, share in zip(weights, shares, strict=True)])

    def sample(self, rng: np.random.Generator, batch: int) -> WindowBatch:
        span = CONTEXT_FRAMES + enc.FRAMES
        qpos = np.empty((batch, span, 36))
        contacts = np.zeros((batch, enc.FRAMES, 2))
        length = np.empty(batch, dtype=np.int64)
        real = np.empty(batch, dtype=np.int64)  # plan frames of each window that are the clip's, not padding
        captions: list[str | None] = []
        for b, index in enumerate(rng.choice(len(self.clips), size=batch, p=self._weights)):
            clip_q, clip_c, clip_captions = self.clips[index]
            fits = [n for n in ALLOWED_LENGTHS if CONTEXT_FRAMES + n <= len(clip_q)]
            n = int(rng.choice(fits))
            start = int(rng.integers(0, len(clip_q) - CONTEXT_FRAMES - n + 1))
            piece = clip_q[start : start + span]
            qpos[b, : len(piece)] = piece
            qpos[b, len(piece) :] = piece[-1]  # padding beyond the plan length is never used
            contacts[b, :n] = clip_c[start + CONTEXT_FRAMES : start + CONTEXT_FRAMES + n]
            length[b] = n
            real[b] = len(piece) - CONTEXT_FRAMES
            captions.append(caption_in_force(clip_captions, start + CONTEXT_FRAMES, start + CONTEXT_FRAMES + n))
        origin_xy, origin_yaw = ft.frame_origin(qpos[:, CONTEXT_FRAMES - 1])
        channels = ft.to_channels(qpos, origin_xy, origin_yaw)
        context, truth = channels[:, :CONTEXT_FRAMES], channels[:, CONTEXT_FRAMES:]
        mask = random_constraints(rng, length, self.free_share)
        velocities, velocity_mask = keyframe_velocities(rng, truth, mask, real, self.velocity_share)
        curve, window = ft.anchor_curve(context, truth, mask, velocities, velocity_mask, self.fade_frames)
        if (self.momentum_with_velocity or self.velocity_fade_delay > 0) and self.fade_frames is not None:
            kept, _ = ft.anchor_curve(
                context, truth, mask, velocities, velocity_mask, self.fade_frames, not self.momentum_with_velocity, self.velocity_fade_delay
            )
            given = np.asarray(velocity_mask.any(axis=(-2, -1)))
            curve = np.where(given[:, None, None], kept, curve)  # as the runtime plans it
        if self.text is None:
            text, has_text = np.zeros((batch, TEXT_EMBEDDING_DIM)), np.zeros(batch, dtype=bool)
        else:
            text, has_text = self.text.draw(rng, captions)
        cond = enc.conditioning(context, curve, mask, length, text, has_text)
        target = enc.residual_target(truth, contacts, curve, length)
        return WindowBatch(cond, target, curve, window, truth, length, tuple(captions), has_text)


def random_constraints(rng: np.random.Generator, length: NDArray[np.int64], free_share: float = 0.0) -> NDArray[np.bool_]:
    """[B, F, C] masks: a main keyframe near the end, sometimes earlier partial keyframes; none in `free_share` of them."""
    mask = np.zeros((len(length), enc.FRAMES, ft.NUM_CHANNELS), dtype=bool)
    free = rng.random(len(length)) < free_share
    for b, n in enumerate(length):
        if free[b]:
            continue
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


def keyframe_velocities(
    rng: np.random.Generator, truth: FloatArray, mask: NDArray[np.bool_], real: NDArray[np.int64], share: float
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """True channel velocities [B, F, C] (the next frame's difference) at the constrained frames of `share` of the windows.

    A frame gets one only where the clip holds the frame after it (`real` [B] plan frames are the clip's).
    """
    velocities = np.zeros_like(truth)
    velocities[:, :-1] = truth[:, 1:] - truth[:, :-1]
    has_next = np.arange(truth.shape[1])[None, :] + 1 < real[:, None]  # [B, F]
    chosen = rng.random(len(truth)) < share
    return velocities, mask & has_next[..., None] & chosen[:, None, None]
