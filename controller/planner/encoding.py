"""What the network sees and what it predicts, shared by training and the runtime.

Conditioning (one flat vector): the 4 context frames as channels, the anchor curve every
4th frame (it carries the keyframes and the target root), which frames and body groups
are constrained, the plan length (one-hot) and the optional text-embedding slot with its
presence flag. Missing constraints are zeros whose mask entries are zero: the first
layer's weights on the mask entries act as the learned "missing" embeddings.

Prediction: a residual [64, 38] over the anchor curve (36 channels) plus foot contacts
(2, centred on 0.5), zero beyond the plan length.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from controller.planner import features as ft
from controller.planner.request import ALLOWED_LENGTHS, CONTEXT_FRAMES, MAX_LENGTH, TEXT_EMBEDDING_DIM, PlanRequest
from hw import g1

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

SPEC_VERSION = 2  # of the exported model's spec (planner.json): bump when this encoding changes
# 1: a 64-number text slot, never trained. 2: the slot holds an all-MiniLM-L6-v2 sentence embedding (384).
FRAMES = MAX_LENGTH
CURVE_STRIDE = 4
CONTACTS = 2
OUT_CHANNELS = ft.NUM_CHANNELS + CONTACTS


def _joint_channels(group: tuple[str, ...]) -> list[int]:
    return [ft.JOINTS.start + i for i in g1.joint_indices(group)]


GROUPS: tuple[tuple[str, list[int]], ...] = (
    ("root_plan", [0, 1, ft.HEADING]),
    ("root_pose", [ft.ROOT_Z, *range(ft.TILT.start, ft.TILT.stop)]),
    ("legs", _joint_channels(g1.LEG_JOINTS)),
    ("waist", _joint_channels(g1.WAIST_JOINTS)),
    ("arms", _joint_channels(g1.ARM_JOINTS)),
)
_GROUP_MEMBERS = np.zeros((ft.NUM_CHANNELS, len(GROUPS)))  # [C, G]: 1 where channel c is in group g
for _g, (_, _channels) in enumerate(GROUPS):
    _GROUP_MEMBERS[_channels, _g] = 1.0
_GROUP_SIZES = _GROUP_MEMBERS.sum(axis=0)
# Joint-vector slices for the random partial keyframes of training.
_LEGS, _UPPER_BODY, _ARMS = (g1.joint_slice(group) for group in (g1.LEG_JOINTS, g1.UPPER_BODY_JOINTS, g1.ARM_JOINTS))
_ONE_ARM = (g1.joint_slice(g1.LEFT_ARM_JOINTS), g1.joint_slice(g1.RIGHT_ARM_JOINTS))
COND_DIM = (  # context, curve samples, group masks, length one-hot, text slot and flag
    CONTEXT_FRAMES * ft.NUM_CHANNELS
    + (FRAMES // CURVE_STRIDE) * ft.NUM_CHANNELS
    + FRAMES * len(GROUPS)
    + len(ALLOWED_LENGTHS)
    + TEXT_EMBEDDING_DIM
    + 1
)


TEXT_SLOT = slice(COND_DIM - TEXT_EMBEDDING_DIM - 1, COND_DIM)  # the text embedding and its presence flag, last


def conditioning(
    context: FloatArray,
    curve: FloatArray,
    mask: BoolArray,
    length: NDArray[np.int64],
    text: FloatArray | None = None,
    has_text: NDArray[np.bool_] | None = None,
) -> FloatArray:
    """[..., COND_DIM] from context channels [..., 4, C], anchor curve and mask [..., F, C], plan length [...].

    `text` is a sentence embedding [..., 384] (or one for the whole batch); `has_text` [...]
    says which entries carry one (default: all when `text` is given). An entry without text
    gets a zero slot and flag 0.
    """
    batch = context.shape[:-2]
    groups = (mask @ _GROUP_MEMBERS) / _GROUP_SIZES  # [..., F, G]: the share of each group's channels constrained
    one_hot = (np.asarray(length)[..., None] == np.array(ALLOWED_LENGTHS)).astype(np.float64)
    if text is None:
        text_part = np.zeros((*batch, TEXT_EMBEDDING_DIM + 1))
    else:
        flag = np.ones(batch) if has_text is None else np.broadcast_to(np.asarray(has_text, dtype=np.float64), batch)
        slot = np.broadcast_to(text, (*batch, TEXT_EMBEDDING_DIM)) * flag[..., None]
        text_part = np.concatenate((slot, flag[..., None]), axis=-1)
    parts = (
        context.reshape(*batch, -1),
        curve[..., ::CURVE_STRIDE, :].reshape(*batch, -1),
        groups.reshape(*batch, -1),
        one_hot,
        text_part,
    )
    return np.concatenate(parts, axis=-1)


def residual_target(truth: FloatArray, contacts: FloatArray, curve: FloatArray, length: NDArray[np.int64]) -> FloatArray:
    """[..., F, 38] training target from true channels and contacts [..., F, 2] over plan frames."""
    valid = np.arange(FRAMES) < np.asarray(length)[..., None]  # [..., F]
    residual = np.concatenate((truth - curve, contacts - 0.5), axis=-1)
    return np.where(valid[..., None], residual, 0.0)


def request_channels(request: PlanRequest) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """Canonical frame (origin xy, yaw), context channels [4, C], keyframe values and mask [F, C] of a validated request.

    Context and keyframes go through one conversion, each frame on its own: 4 context frames
    (0.1 s) cannot turn by half a revolution, so no unwrapping is lost.
    """
    origin_xy, origin_yaw = ft.frame_origin(request.context[-1])
    frames = np.concatenate((request.context, [key.qpos for key in request.keyframes])) if request.keyframes else request.context
    channels = ft.to_channels(frames[:, None], origin_xy, origin_yaw)[:, 0]
    values = np.zeros((FRAMES, ft.NUM_CHANNELS))
    mask = np.zeros((FRAMES, ft.NUM_CHANNELS), dtype=bool)
    values[[key.frame for key in request.keyframes]] = channels[CONTEXT_FRAMES:]
    for key in request.keyframes:
        mask[key.frame, ft.JOINTS] = key.joints
        if key.root:
            mask[key.frame, [0, 1, ft.HEADING]] = True
        if key.root_height:
            mask[key.frame, ft.ROOT_Z] = True
            mask[key.frame, ft.TILT] = True
    return np.array([*origin_xy, origin_yaw]), channels[:CONTEXT_FRAMES], values, mask


def request_velocities(request: PlanRequest, origin: FloatArray) -> tuple[FloatArray, BoolArray] | None:
    """Channel velocities and their mask [F, C] from the keyframes that carry a velocity; None when none does."""
    given = [key for key in request.keyframes if key.velocity is not None]
    if not given:
        return None
    velocities = np.zeros((FRAMES, ft.NUM_CHANNELS))
    mask = np.zeros((FRAMES, ft.NUM_CHANNELS), dtype=bool)
    for key in given:
        assert key.velocity is not None
        velocities[key.frame] = ft.channel_velocity(key.qpos, key.velocity, origin[:2], origin[2])
        mask[key.frame, ft.JOINTS] = key.joints
        mask[key.frame, [0, 1, ft.HEADING]] = key.root
        mask[key.frame, ft.ROOT_Z] = key.root_height
        mask[key.frame, ft.TILT] = key.root_height
    return velocities, mask


def joint_group_mask(rng: np.random.Generator) -> NDArray[np.bool_]:
    """A random subset of joint groups for a partial keyframe in training: legs, waist, arms, one arm."""
    mask = np.zeros(g1.NUM_JOINTS, dtype=bool)
    choice = rng.integers(5)
    if choice == 0:
        mask[:] = True
    elif choice == 1:
        mask[_ARMS] = True
    elif choice == 2:
        mask[_ONE_ARM[rng.integers(2)]] = True
    elif choice == 3:
        mask[_LEGS] = True
    else:
        mask[_UPPER_BODY] = True  # waist and arms
    return mask
