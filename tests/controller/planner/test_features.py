"""Canonical channels, the anchor curve and plan-request validation (pure numpy, no model)."""

from __future__ import annotations

import numpy as np
import pytest

from controller.planner import encoding as enc
from controller.planner import features as ft
from controller.planner.request import TEXT_EMBEDDING_DIM, Keyframe, PlanRequest, PlanRequestError, target_root
from hw import quat
from tests.conftest import turning_walk


def test_channels_round_trip_and_canonical_origin() -> None:
    qpos = turning_walk()
    origin_xy, origin_yaw = ft.frame_origin(qpos[3])
    channels = ft.to_channels(qpos, origin_xy, origin_yaw)
    assert np.allclose(channels[3, [0, 1, ft.HEADING]], 0.0, atol=1e-12)
    assert np.all(np.diff(channels[:, ft.HEADING]) > 0)  # unwrapped through +-pi
    back = ft.from_channels(channels, origin_xy, origin_yaw)
    sign = np.sign(np.sum(back[:, 3:7] * qpos[:, 3:7], axis=-1, keepdims=True))
    assert np.allclose(back[:, :3], qpos[:, :3]) and np.allclose(back[:, 7:], qpos[:, 7:])
    assert np.allclose(back[:, 3:7] * sign, qpos[:, 3:7], atol=1e-12)


def test_channels_do_not_depend_on_where_the_robot_stands() -> None:
    qpos = turning_walk()
    moved = qpos.copy()
    moved[:, :2] = ft.rotate_xy(qpos[:, :2], np.full(len(qpos), 1.3)) + np.array([10.0, 4.0])
    moved[:, 3:7] = quat.multiply(quat.from_yaw(np.full(len(qpos), 1.3)), qpos[:, 3:7])
    a = ft.to_channels(qpos, *ft.frame_origin(qpos[3]))
    b = ft.to_channels(moved, *ft.frame_origin(moved[3]))
    assert np.allclose(a, b, atol=1e-9)


def test_anchor_curve_meets_constraints_and_continues_the_context() -> None:
    channels = ft.to_channels(turning_walk(), *ft.frame_origin(turning_walk()[3]))
    context, truth = channels[None, :4], channels[None, 4:68]
    mask = np.zeros_like(truth, dtype=bool)
    mask[0, 40] = True
    mask[0, 20, ft.JOINTS] = True
    curve, window = ft.anchor_curve(context, truth, mask)
    assert np.allclose(curve[0, 40], truth[0, 40]) and np.allclose(curve[0, 20, ft.JOINTS], truth[0, 20, ft.JOINTS])
    assert np.all(window[0, 40] == 0) and np.all(window[0, 20, ft.JOINTS] == 0) and np.all(window[0, 30] > 0)
    start_velocity = context[0, -1] - context[0, -2]
    root = [0, 1, ft.HEADING]  # constrained 41 frames on: the curve leaves the context at the context's velocity
    assert np.allclose(curve[0, 0, root] - context[0, -1, root], start_velocity[root], atol=2e-3)
    assert window[0, 0].max() < 0.2  # the residual fades in from the context
    unconstrained = np.zeros_like(mask)
    drift, _ = ft.anchor_curve(context, truth, unconstrained)
    assert np.allclose(drift[0, 9, 0], context[0, -1, 0] + 10 * start_velocity[0])  # a free root keeps its velocity


def test_conditioning_has_the_declared_size() -> None:
    rng = np.random.default_rng(0)
    cond = enc.conditioning(rng.normal(size=(3, 4, 36)), rng.normal(size=(3, 64, 36)), np.zeros((3, 64, 36), bool), np.array([24, 44, 64]))
    assert cond.shape == (3, enc.COND_DIM)


def test_text_slot_per_window_and_its_flag() -> None:
    rng = np.random.default_rng(0)
    args = (rng.normal(size=(3, 4, 36)), rng.normal(size=(3, 64, 36)), np.zeros((3, 64, 36), bool), np.array([24, 44, 64]))
    text = rng.normal(size=(3, TEXT_EMBEDDING_DIM))
    cond = enc.conditioning(*args, text, np.array([True, False, True]))
    slot = cond[:, enc.TEXT_SLOT]
    assert slot.shape == (3, TEXT_EMBEDDING_DIM + 1)
    assert np.allclose(slot[0, :-1], text[0]) and slot[0, -1] == 1.0
    assert not slot[1].any()  # no text: zeros and flag 0
    assert np.allclose(enc.conditioning(*args)[:, enc.TEXT_SLOT], 0.0)
    one = enc.conditioning(*args, text[0])  # one embedding for the whole batch, all flagged
    assert np.allclose(one[:, enc.TEXT_SLOT][:, :-1], text[0]) and (one[:, -1] == 1).all()
    assert np.allclose(cond[:, : enc.TEXT_SLOT.start], one[:, : enc.TEXT_SLOT.start])  # text touches nothing else


def test_request_validation_names_the_problem() -> None:
    context = turning_walk()[:4]
    good = PlanRequest(context, (Keyframe(30, turning_walk()[34]), target_root(43, 1.0, 0.0, 0.0)), (44,))
    assert good.validated().plan_length() == 44
    cases = {
        "context must have shape [4, 36]": PlanRequest(context[:3]),
        "holds NaN": PlanRequest(np.where(np.eye(4, 36) > 0, np.nan, context)),
        "unknown plan mode 'dance'": PlanRequest(context, mode="dance"),
        "plan lengths [30] are not allowed": PlanRequest(context, lengths=(30,)),
        "outside a plan of at most 44 frames": PlanRequest(context, (Keyframe(50, context[0]),)),
        "joint mask must have 29 entries": PlanRequest(context, (Keyframe(5, context[0], joints=np.ones(3, bool)),)),
        "two keyframes at the same frame": PlanRequest(context, (Keyframe(5, context[0]), Keyframe(5, context[1]))),
        "text embedding must have shape [384]": PlanRequest(context, text_embedding=np.zeros(3)),
    }
    for message, request in cases.items():
        with pytest.raises(PlanRequestError, match=message.replace("[", r"\[").replace("]", r"\]")):
            request.validated()


def test_a_keyframe_velocity_makes_the_anchor_the_hermite_baseline() -> None:
    from controller.bench import baselines

    walk = turning_walk(60)
    target, after, length = walk[4 + 30], walk[4 + 31], 30
    velocity = baselines.finite_velocity(target, after)
    request = PlanRequest(walk[:4], (Keyframe(length, target, velocity=velocity),), lengths=(32,)).validated()
    origin, context, values, mask = enc.request_channels(request)
    given = enc.request_velocities(request, origin)
    assert given is not None and given[1][length].all() and not given[1][length - 1].any()
    # The channel velocity of the true next frame is the channels' own difference.
    truth = ft.to_channels(walk[4 + length : 4 + length + 2], origin[:2], origin[2])
    assert np.allclose(given[0][length], truth[1] - truth[0], atol=1e-9)
    curve, _ = ft.anchor_curve(context, values, mask, *given)
    hermite = baselines.hermite(walk[:4], target, length, velocity)
    planned = ft.from_channels(curve[:length], origin[:2], origin[2])
    assert np.allclose(planned[:, 7:], hermite[:, 7:], atol=1e-9) and np.allclose(planned[:, :3], hermite[:, :3], atol=1e-9)
    plain, _ = ft.anchor_curve(context, values, mask)
    assert np.abs(plain - curve)[: length - 1, ft.JOINTS].max() > 1e-3  # without it the curve arrives along the chord
    faded, _ = ft.anchor_curve(context, values, mask, *given, fade_frames=4.0)
    assert np.allclose(faded[length], values[length]) and np.allclose(
        faded[length] - faded[length - 1], curve[length] - curve[length - 1], atol=0.02
    )
    mid = length // 2  # far from both ends the faded velocities add little to the chord's straight line
    chord = context[-1] + (mid + 1) / (length + 1) * (values[length] - context[-1])
    assert np.abs(faded[mid] - chord).max() < 0.2 * np.abs(curve[mid] - chord).max()
    # Keeping the root's momentum: the horizontal root follows the unfaded curve, every other channel the faded one.
    momentum, _ = ft.anchor_curve(context, values, mask, *given, fade_frames=4.0, fade_root_xy=False)
    assert np.allclose(momentum[:, ft.ROOT_XY], curve[:, ft.ROOT_XY]) and np.allclose(momentum[:, 2:], faded[:, 2:])
    assert np.abs(faded - curve)[:length, ft.ROOT_XY].max() > 1e-3
    # A fade delay carries each velocity whole that many frames from its end: over a gap no longer, the plain Hermite.
    delayed, _ = ft.anchor_curve(context, values, mask, *given, fade_frames=4.0, fade_delay=length + 1.0)
    assert np.allclose(delayed, curve)
    assert np.array_equal(ft.anchor_curve(context, values, mask, *given, fade_frames=4.0, fade_delay=0.0)[0], faded)
    # The context's velocity alone (no keyframe velocity): whole for the first 8 frames after the context, then fading.
    short, _ = ft.anchor_curve(context, values, mask, fade_frames=4.0, fade_delay=8.0)
    assert np.allclose(short[:8], plain[:8]) and np.abs(short[12:length] - plain[12:length]).max() > 1e-3


def test_keyframe_velocity_is_validated() -> None:
    walk = turning_walk(10)
    for bad, message in (
        (np.zeros(34), r"keyframe 5 velocity must have shape \[35\]"),
        (np.full(35, np.nan), "keyframe 5 velocity holds NaN"),
    ):
        with pytest.raises(PlanRequestError, match=message):
            PlanRequest(walk[:4], (Keyframe(5, walk[9], velocity=bad),)).validated()
