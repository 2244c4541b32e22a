"""Gestures as arm keyframes: which joints, which frames, which angles, and the shipped planner meeting them."""

from __future__ import annotations

import numpy as np
import pytest

from controller.commands.gestures import BLEND_S, GESTURE_LABELS, GesturePlayer, smoothstep
from controller.inputs.scripted import load_scenario
from controller.planner.request import FPS, Keyframe, PlanRequest
from controller.planner.runtime import Planner
from controller.reference.gestures import Gesture, GestureConfig, GestureLibrary, merged
from controller.reference.locomotion import SmartLocomotion
from hw import g1
from hw.errors import ConfigError
from hw.shipped import model_dir

ARMS = np.zeros(g1.NUM_JOINTS, dtype=bool)
ARMS[g1.joint_indices(g1.ARM_JOINTS)] = True
RIGHT_ARM = np.zeros(g1.NUM_JOINTS, dtype=bool)
RIGHT_ARM[g1.joint_indices(g1.RIGHT_ARM_JOINTS)] = True
BASE = np.array(g1.default_joint_vector())
CONTEXT = np.tile(g1.standing_qpos(), (4, 1))


def player_angles(name: str, start: float, t: float) -> np.ndarray:
    """What the dataset's gesture player gives at run time t for a gesture that started at `start` (blend in only)."""
    unbounded = np.full(g1.NUM_JOINTS, np.inf)
    player = GesturePlayer(g1.JOINT_NAMES, -unbounded, unbounded)
    return player.apply(BASE, GESTURE_LABELS.index(name), smoothstep((t - start) / BLEND_S), t - start)


def test_every_gesture_holds_only_arm_joints_and_wave_is_the_right_arm() -> None:
    library = GestureLibrary()
    assert set(library.names) == set(GESTURE_LABELS) - {"none"}
    for style in library.styles.values():
        assert style.arms.any() and not (style.arms & ~ARMS).any(), style.name  # no leg or waist joint, ever
    wave = library.style("wave")
    assert not (wave.arms & ~RIGHT_ARM).any()  # the wave is the right hand's; the left arm keeps the planner's swing
    assert library.style("raise_both").arms.sum() > wave.arms.sum()


def test_keyframes_sit_on_the_last_frame_and_every_spacing_back_with_the_players_angles() -> None:
    library = GestureLibrary()
    first = 3.0 + 1 / FPS  # plan frame k at 3.0 + (k + 1) / FPS
    for name, spacing in (("raise_both", 4), ("wave", 2)):
        gesture = Gesture(name, start=1.0)
        keyframes = library.keyframes([gesture], first, 44)
        assert [k.frame for k in keyframes] == list(range(43, 0, -spacing))[::-1]  # never frame 0: the plan leaves the context
        style = library.style(name)
        for k in keyframes:
            assert not k.root and not k.root_height
            np.testing.assert_array_equal(k.joints, style.arms)
            expected = player_angles(name, 1.0, first + k.frame / FPS)
            np.testing.assert_allclose(k.qpos[g1.QPOS_JOINTS][k.joints], expected[k.joints], atol=1e-12)


def test_a_gesture_blends_in_over_half_a_second_after_it_starts() -> None:
    library = GestureLibrary()
    start = 2.0
    keyframes = library.keyframes([Gesture("raise_right", start)], start + 0.1, 44)
    pitch = g1.JOINT_NAMES.index("right_shoulder_pitch_joint")
    values = [k.qpos[g1.QPOS_JOINTS][pitch] for k in keyframes]
    times = [start + 0.1 + k.frame / FPS for k in keyframes]
    target = player_angles("raise_right", start, start + 10.0)[pitch]
    assert np.all(np.diff(values) <= 1e-12)  # rising (pitch goes negative) without overshoot
    for t, v in zip(times, values, strict=True):
        w = smoothstep((t - start) / BLEND_S)
        assert v == pytest.approx(BASE[pitch] + w * (target - BASE[pitch]))
    assert values[0] > BASE[pitch] + 0.5 * (target - BASE[pitch])  # early: still near the base pose
    assert values[-1] == pytest.approx(target)  # after the blend: the gesture itself


def test_straight_lines_between_wave_keyframes_stay_within_the_tolerance() -> None:
    cfg = GestureConfig()
    library = GestureLibrary(cfg)
    gesture = Gesture("wave", start=0.0)
    first = 5.0
    keyframes = library.keyframes([gesture], first, 44)
    frames = np.array([k.frame for k in keyframes], dtype=float)
    elbow = g1.JOINT_NAMES.index("right_elbow_joint")
    values = np.array([k.qpos[g1.QPOS_JOINTS][elbow] for k in keyframes])
    fine = np.linspace(frames[0], frames[-1], 400)
    exact = np.array([library.arm_angles([gesture], first + f / FPS)[0][elbow] for f in fine])
    assert np.abs(np.interp(fine, frames, values) - exact).max() <= cfg.tolerance
    assert np.ptp(values) > 0.7  # the 0.4 rad elbow wave is there, not aliased away


def test_no_gesture_no_keyframes_and_an_unknown_name_lists_the_valid_ones() -> None:
    library = GestureLibrary()
    assert library.keyframes([], 1.0, 44) == ()
    locomotion = SmartLocomotion()
    locomotion.set_gesture("", 0.0)
    locomotion.set_gesture("none", 0.5)
    assert locomotion.gesture is None and locomotion.gestures == ()
    assert locomotion.request(CONTEXT, 1.0).keyframes[0].joints.sum() == 0  # only the root target
    with pytest.raises(ConfigError, match=r"unknown gesture 'moonwalk'.*wave.*raise_both.*point"):
        locomotion.set_gesture("moonwalk", 1.0)
    with pytest.raises(ConfigError, match="unknown gesture 'salute'"):
        library.style("salute")


def test_holding_the_free_arms_keeps_the_arm_joints_the_gesture_does_not_move_on_the_base_pose() -> None:
    library = GestureLibrary()
    first = 3.0
    assert library.keyframes([], first, 44) == ()  # no gesture, free arms: the arms are the planner's
    rest = library.keyframes([], first, 44, hold_rest=True)  # held: on the base pose over the whole plan
    assert [k.frame for k in rest] == list(range(43, 0, -4))[::-1]
    assert all(np.array_equal(k.joints, ARMS) and np.allclose(k.qpos[g1.QPOS_JOINTS][ARMS], BASE[ARMS]) for k in rest)
    raised = library.keyframes([Gesture("raise_right", start=0.0)], first, 44, hold_rest=True)
    right = library.style("raise_right").arms
    assert [k.frame for k in raised] == list(range(43, 0, -4))[::-1]
    for k in raised:  # the right arm does the gesture, the left one stays down
        np.testing.assert_array_equal(k.joints, ARMS)
        np.testing.assert_allclose(k.qpos[g1.QPOS_JOINTS][ARMS & ~right], BASE[ARMS & ~right], atol=1e-12)
        expected = player_angles("raise_right", 0.0, first + k.frame / FPS)
        np.testing.assert_allclose(k.qpos[g1.QPOS_JOINTS][right], expected[right], atol=1e-12)
    locomotion = SmartLocomotion()
    locomotion.hold_free_arms = True
    locomotion.set_gesture("raise_right", 0.0)
    held = locomotion.request(CONTEXT, 1.0).keyframes
    assert held[-1].root and np.array_equal(held[-1].joints, ARMS)  # the last arm keyframe merged into the root target


def test_the_gesture_keeps_its_start_while_asked_for_and_blends_out_after_it_ends() -> None:
    locomotion = SmartLocomotion()
    locomotion.set_gesture("wave", 1.0)
    locomotion.set_gesture("wave", 1.5)  # every tick asks again: the start stays
    assert not locomotion.set_gesture("wave", 1.6) and locomotion.gesture == Gesture("wave", 1.0)
    assert locomotion.set_gesture("raise_both", 4.0)
    assert locomotion.gesture == Gesture("raise_both", 4.0)
    assert locomotion.gestures == (Gesture("wave", 1.0, end=4.0), Gesture("raise_both", 4.0))
    locomotion.set_gesture("", 8.0)
    assert locomotion.gesture is None
    roll = g1.JOINT_NAMES.index("left_shoulder_roll_joint")
    request = locomotion.request(CONTEXT, 8.0)  # frames from 8.033 s: raise_both blends out over 0.5 s
    arms = [k for k in request.keyframes if k.joints.any()]
    values = [k.qpos[g1.QPOS_JOINTS][roll] for k in arms]
    assert values[0] > 1.5 and np.all(np.diff(values) <= 1e-12)  # the arm comes down from out to the side (2.0 rad)
    after = [v for k, v in zip(arms, values, strict=True) if 8.0 + (k.frame + 1) / FPS >= 8.0 + BLEND_S - 1e-9]
    assert after and after == pytest.approx([BASE[roll]] * len(after))  # blended out: back on the base pose
    assert locomotion.request(CONTEXT, 9.0).keyframes[0].joints.sum() == 0  # faded: the arms are the planner's again
    assert locomotion.gestures == ()


def test_one_gesture_per_arm_at_once_each_kept_ended_or_started_on_its_own() -> None:
    locomotion = SmartLocomotion()
    assert locomotion.set_gestures(("wave_left", "raise_right"), 1.0)
    assert locomotion.in_force == ("wave_left", "raise_right")
    assert not locomotion.set_gestures(("raise_right", "wave_left"), 1.2)  # the same tracks: nothing restarts
    assert locomotion.set_gestures(("raise_right",), 3.0)  # the right arm's pose held on, the wave ends
    assert locomotion.gestures == (Gesture("wave_left", 1.0, end=3.0), Gesture("raise_right", 1.0))
    request = locomotion.request(CONTEXT, 2.0)
    arms = [k for k in request.keyframes if k.joints.any()]
    left_elbow, right_roll = g1.JOINT_NAMES.index("left_elbow_joint"), g1.JOINT_NAMES.index("right_shoulder_roll_joint")
    assert all(k.joints[left_elbow] and k.joints[right_roll] for k in arms[:3])  # both arms shaped while the wave blends out
    expected = player_angles("raise_right", 1.0, 2.0 + (arms[0].frame + 1) / FPS)
    assert arms[0].qpos[g1.QPOS_JOINTS][right_roll] == pytest.approx(expected[right_roll])


def test_arms_on_the_root_targets_frame_merge_into_it() -> None:
    locomotion = SmartLocomotion()
    locomotion.set_gesture("point", 0.0)
    request = locomotion.request(CONTEXT, 2.0).validated()
    frames = [k.frame for k in request.keyframes]
    assert len(set(frames)) == len(frames) and frames[-1] == 43
    last = request.keyframes[-1]
    assert last.root and not last.root_height  # the spring's target root, as without a gesture
    np.testing.assert_array_equal(last.joints, locomotion.library.style("point").arms)
    with pytest.raises(ConfigError, match="cannot merge"):
        merged(last, Keyframe(5, last.qpos))


@pytest.mark.skipif(not (model_dir("planner") / "planner.onnx").is_file(), reason="no shipped planner model")
@pytest.mark.parametrize("name", ["wave", "raise_both", "hands_on_hips"])
def test_the_shipped_planner_puts_the_arms_on_the_keyframes(name: str) -> None:
    planner = Planner.load()
    locomotion = SmartLocomotion(seed=2)
    locomotion.set_gesture(name, 0.0)
    request = locomotion.request(CONTEXT, 0.2)  # mid blend: the angles change along the plan
    assert isinstance(request, PlanRequest) and len(request.validated().keyframes) > 5
    plan = planner.plan(request)
    for k in (k for k in request.keyframes if k.joints.any()):
        joints = plan.qpos[k.frame, g1.QPOS_JOINTS][k.joints]
        assert np.abs(joints - k.qpos[g1.QPOS_JOINTS][k.joints]).max() <= 0.05, k.frame


def test_the_gesture_scenarios_load() -> None:
    wave = load_scenario("wave")
    assert [s.gesture for s in wave.steps] == ["", "wave", "raise_both", ""] and wave.duration == 12.0
    walk = load_scenario("walk_and_wave")
    assert any(s.gesture == "wave" and s.vx > 0 for s in walk.steps) and any(s.gesture == "wave" and s.yaw_rate for s in walk.steps)
