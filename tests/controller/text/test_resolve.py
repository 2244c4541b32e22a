"""Prompts resolved to behaviour programs: every behaviour's handler, arm tracks, curves, repetitions, refusals, the suite.

The sentence encoder decides nothing that runs: these tests plan with an encoder that knows no
phrase (`OrthogonalEncoder`) and get the same programs; only the refusal's explanation uses the
real one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
import yaml
from numpy.typing import NDArray

from controller.assets import Assets
from controller.text.encoder import SentenceEncoder
from controller.text.program import GESTURE_NAMES, Curve, Motion, Program, PromptRefused
from controller.text.resolve import MAX_CLAUSES, describe_program, end_pose, plan_program

SUITE = Path(__file__).resolve().parents[3] / "configs" / "prompts" / "suite.yaml"


@pytest.fixture(scope="module")
def encoder(assets: Assets) -> SentenceEncoder:
    return SentenceEncoder.load(assets)


class OrthogonalEncoder:
    """A stand-in that knows no phrase: every text gets its own direction."""

    def __init__(self) -> None:
        self.seen: dict[str, int] = {}

    def embed(self, texts: Sequence[str]) -> NDArray[np.float32]:
        out = np.zeros((len(texts), 4096), dtype=np.float32)
        for i, t in enumerate(texts):
            out[i, self.seen.setdefault(t, len(self.seen))] = 1.0
        return out


def _program(prompt: str, encoder: object | None = None) -> Program:
    return plan_program(prompt, encoder or OrthogonalEncoder())  # type: ignore[arg-type]


def _ends(prompt: str) -> list[tuple[float, float, float]]:
    return [tuple(round(v, 3) for v in c.displacement) for c in _program(prompt).clauses]  # type: ignore[misc]


# --- base motions ---


@pytest.mark.parametrize(
    ("prompt", "ends"),
    [
        ("walk forward two meters", [(2.0, 0.0, 0.0)]),
        ("take three steps back", [(-0.9, 0.0, 0.0)]),
        ("step to the right", [(0.0, -0.3, 0.0)]),
        ("move sideways a little", [(0.0, 0.5, 0.0)]),
        ("walk diagonally forward and to the left for 2 m", [(1.414, 1.414, 0.0)]),
        ("walk 1 m forward and 2 m to the left", [(1.0, 2.0, 0.0)]),
        ("walk forward for 4 seconds quickly", [(3.2, 0.0, 0.0)]),
        ("back up", [(-1.0, 0.0, 0.0)]),
        ("walk 4 steps back, then 2 to the right", [(-1.2, 0.0, 0.0), (0.0, -0.6, 0.0)]),
        ("turn left", [(0.0, 0.0, 90.0)]),
        ("turn around", [(0.0, 0.0, 180.0)]),
        ("spin around", [(0.0, 0.0, 360.0)]),
        ("turn right 45", [(0.0, 0.0, -45.0)]),
        ("do a 180", [(0.0, 0.0, 180.0)]),
        ("make a u-turn", [(0.0, 0.0, 180.0)]),
        ("make a quarter turn clockwise", [(0.0, 0.0, -90.0)]),
        ("wait 3 seconds", [(0.0, 0.0, 0.0)]),
    ],
)
def test_base_motions(prompt: str, ends: list[tuple[float, float, float]]) -> None:
    assert _ends(prompt) == [pytest.approx(e, abs=1e-3) for e in ends]


def test_there_and_back_is_two_legs() -> None:
    (clause,) = _program("walk forward half a meter and back").clauses
    assert isinstance(clause.motion, Motion)
    assert [(w.forward_m, w.left_m) for w in clause.motion.waypoints] == [(0.5, 0.0), (0.0, 0.0)]


def test_a_stated_speed_and_a_distance_in_a_time() -> None:
    (a,) = _program("walk forward 2 m at 0.4 meters per second").clauses
    (b,) = _program("walk forward 1 m in 5 seconds").clauses
    assert a.motion is not None and a.motion.speed_mps == 0.4
    assert b.motion is not None and b.motion.speed_mps == pytest.approx(0.2)


def test_large_turns_are_split_into_pieces_the_follower_turns_the_intended_way() -> None:
    (clause,) = _program("turn left 270 degrees").clauses
    assert isinstance(clause.motion, Motion)
    assert [w.heading_deg for w in clause.motion.waypoints] == [90.0, 180.0, 270.0]


def test_come_back_walks_straight_to_the_start_without_turning() -> None:
    ends = _ends("walk forward 1 m, turn left, walk forward 1 m, then come back")
    assert ends[-1] == pytest.approx((-1.0, 1.0, 0.0), abs=1e-3)
    program = _program("walk forward 1 m, turn left, walk forward 1 m, then come back")
    assert end_pose(program.clauses)[:2] == pytest.approx((0, 0), abs=1e-9)


def test_bare_go_back_returns_but_a_distance_walks_backward() -> None:
    assert _ends("walk forward 2 m, then go back")[-1] == pytest.approx((-2.0, 0.0, 0.0))
    assert _ends("walk forward 2 m, then go back 50 cm")[-1] == pytest.approx((-0.5, 0.0, 0.0))


# --- curves ---


def test_a_circle_is_one_continuous_curve() -> None:
    (left,) = _program("walk in a circle").clauses
    (right,) = _program("walk in a circle to the right with a radius of 0.5 m").clauses
    assert isinstance(left.motion, Curve) and isinstance(right.motion, Curve)
    assert left.displacement == pytest.approx((0.0, 0.0, 360.0), abs=1e-9)
    assert right.displacement == pytest.approx((0.0, 0.0, -360.0), abs=1e-9)
    assert right.motion.arcs[0].radius_m == 0.5 and left.motion.length_m == pytest.approx(2 * math.pi)


@pytest.mark.parametrize(
    ("prompt", "end"),
    [
        ("walk an arc to the left", (1.0, 1.0, 90.0)),
        ("walk in an arc of 180 degrees to the right with a radius of 2 m", (0.0, -4.0, -180.0)),
        ("walk a semicircle 1 m across", (0.0, 1.0, 180.0)),
        ("walk forward while turning left 90 degrees", (1.0, 1.0, 90.0)),
        ("walk forward 3.1416 m while turning right 180 degrees", (0.0, -2.0, -180.0)),
        ("do a figure eight", (0.0, 0.0, 0.0)),
        ("walk two circles with a radius of 0.5 m", (0.0, 0.0, 720.0)),
    ],
)
def test_curves_end_where_their_geometry_says(prompt: str, end: tuple[float, float, float]) -> None:
    (clause,) = _program(prompt).clauses
    assert isinstance(clause.motion, Curve)
    assert clause.displacement == pytest.approx(end, abs=1e-3)


def test_a_figure_eight_turns_both_ways_and_the_side_said_first_goes_first() -> None:
    (clause,) = _program("walk a figure 8 starting to the right").clauses
    assert isinstance(clause.motion, Curve)
    assert [a.angle_deg for a in clause.motion.arcs] == [-360.0, 360.0]


def test_a_tight_curve_is_walked_slower() -> None:
    (clause,) = _program("walk in a circle with a radius of 0.3 m").clauses
    assert isinstance(clause.motion, Curve) and clause.motion.speed_mps == pytest.approx(0.36)


# --- arm tracks ---


@pytest.mark.parametrize(
    ("prompt", "gestures", "seconds"),
    [
        ("wave", ("wave_right",), 3.0),
        ("wave with both hands", ("wave_both",), 3.0),
        ("wave 3 times", ("wave_right",), 2.5),
        ("put your hands up for 5 seconds", ("raise_both",), 5.0),
        ("raise your left arm", ("raise_left",), 3.0),
        ("point ahead", ("point",), 3.0),
        ("cross your arms", ("arms_crossed",), 3.0),
        ("put your hands on your hips", ("hands_on_hips",), 3.0),
        ("wave with your left hand while raising your right arm", ("wave_left", "raise_right"), 3.0),
        ("wave with one hand while raising the other", ("wave_right", "raise_left"), 3.0),
    ],
)
def test_gestures_in_place(prompt: str, gestures: tuple[str, ...], seconds: float) -> None:
    (clause,) = _program(prompt).clauses
    assert clause.motion is None and clause.gestures == gestures and clause.min_duration_s == pytest.approx(seconds)


def test_gestures_ride_on_a_motion_for_as_long_as_it_lasts() -> None:
    (clause,) = _program("turn left with both arms raised").clauses
    assert clause.gestures == ("raise_both",) and clause.min_duration_s == 0.0 and clause.displacement[2] == 90.0
    (walk,) = _program("walk forward 2 m while pointing ahead and waving with your left hand").clauses
    assert walk.gestures == ("point", "wave_left")


def test_a_pose_is_held_only_when_asked() -> None:
    held = _program("raise your right arm, then keep it up while you turn left").clauses
    plain = _program("raise your right arm, then turn left").clauses
    assert [c.gestures for c in held] == [("raise_right",), ("raise_right",)]
    assert [c.gestures for c in plain] == [("raise_right",), ()]


def test_lowering_the_arms_is_a_short_stand_without_gestures() -> None:
    clauses = _program("raise both arms, then lower them").clauses
    assert clauses[1].gestures == () and clauses[1].motion is None and clauses[1].min_duration_s == 1.0


@pytest.mark.parametrize(
    "prompt",
    [
        "wave with your right hand while raising your right arm",
        "point while waving",
        "cross your arms while waving with your left hand",
        "raise both arms, then keep them up while you wave",
    ],
)
def test_one_gesture_per_arm(prompt: str) -> None:
    with pytest.raises(PromptRefused, match="one gesture per arm"):
        _program(prompt)


# --- repetitions ---


def test_a_repetition_is_a_clause_of_its_own() -> None:
    program = _program("turn right twice, then wave twice")
    assert [c.displacement[2] for c in program.clauses] == [-90.0, -90.0, 0.0]
    assert program.typed_clauses == 2 and [c.source for c in program.clauses] == [0, 0, 1]
    assert program.clauses[2].quantities["waves"] == 2


def test_do_it_again_repeats_the_clause_before() -> None:
    program = _program("walk left 50 cm. Do that again.")
    assert [c.displacement[:2] for c in program.clauses] == [(0.0, 0.5), (0.0, 0.5)]
    assert end_pose(_program("turn left 45 degrees, then do it again twice").clauses) == pytest.approx((0.0, 0.0, 135.0))


# --- refusals ---


@pytest.mark.parametrize(
    ("prompt", "named"),
    [
        ("walk forward 500 meters", "10 m one clause may walk"),
        ("turn 5000 degrees to the left", "720"),
        ("wait for minus three seconds", '"minus"'),
        ("wait 0 seconds", "must be positive"),
        ("wave 100 times", "a whole number from 1 to 10"),
        ("walk forward 1 m at 3 meters per second", "3 m/s"),
        ("walk three meters forward, then five more", "no unit"),
        ("turn left 3 m", '"3 m" does not go with turning'),
        ("walk forward with a radius of 2 m", "does not go with walking"),
        ("walk in a circle of 2 m", "radius or the diameter"),
        ("walk in a circle with a radius of 10 m", "radius"),
        ("walk sideways while turning left", "forward only"),
        ("walk forward while turning left while spinning", "one movement at a time"),
        ("do it again", "nothing before it"),
        ("keep walking forward", "how far"),
        ("keep waving", "how long"),
        ("point with your left hand", "right arm only"),
        ("walk in place", "in place"),
        ("put your hands", "say where"),
        ("do", "names no action"),
    ],
)
def test_refusals_name_what_is_wrong_in_one_line(prompt: str, named: str) -> None:
    with pytest.raises(PromptRefused) as info:
        _program(prompt)
    message = str(info.value)
    assert named in message and "\n" not in message
    assert message.startswith("cannot plan") and "it can walk" in message


def test_too_many_clauses() -> None:
    with pytest.raises(PromptRefused, match=f"at most {MAX_CLAUSES}"):
        _program("turn left 30 degrees 7 times, then turn right 30 degrees 6 times")


@pytest.mark.parametrize("prompt", ["", "   ", "walk forward " * 50, b"\xff\xfe walk", "\x00\x01", "123 456", 42])
def test_bad_input_is_refused(prompt: object) -> None:
    with pytest.raises(PromptRefused, match="cannot plan"):
        _program(prompt)  # type: ignore[arg-type]


def test_refusal_is_also_a_value_error() -> None:
    with pytest.raises(ValueError, match="flips"):
        _program("do a backflip")


def test_unknown_words_are_refused_with_the_nearest_behaviour(encoder: SentenceEncoder) -> None:
    with pytest.raises(PromptRefused) as info:
        _program("boot the football", encoder)
    assert '"boot", "football"' in str(info.value) and "kicking" in str(info.value)
    with pytest.raises(PromptRefused, match="closest to waving"):
        _program("greet the crowd with a flourish", encoder)
    with pytest.raises(PromptRefused) as vague:
        _program("perambulate forward", encoder)  # nearest "reaching", too far to name
    assert "closest" not in str(vague.value)


def test_the_encoder_decides_nothing_that_runs(encoder: SentenceEncoder) -> None:
    prompt = "stroll ahead a couple of meters, pivot right, then greet us with your left hand"
    assert _program(prompt, encoder) == _program(prompt, OrthogonalEncoder())


def test_describe_program_has_one_line_per_clause() -> None:
    p = _program("walk forward two meters, then turn left 90 degrees, then wave with your right hand")
    lines = describe_program(p).splitlines()
    assert len(lines) == 4 and lines[0].startswith('1. "walk forward 2 meters"')
    assert "distance_m=2" in lines[0] and "+2.00 m fwd" in lines[0]
    assert "wave_right" in lines[2] and "3.0 s" in lines[2]
    assert lines[3].startswith("total: +2.00 m fwd +0.00 m left +90 deg")
    assert "curve of 1 arcs" in describe_program(_program("walk in a circle"))


# --- the prompt suite ---


def _suite() -> list[dict]:
    return yaml.safe_load(SUITE.read_text())["prompts"]


def _execution_s(program: Program) -> float:
    """A rough duration at the planned speeds: path / speed + turning / rate, at least each clause's minimum."""
    total = 0.0
    for clause in program.clauses:
        seconds = 0.0
        if isinstance(clause.motion, Curve):
            seconds = clause.motion.length_m / clause.motion.speed_mps
        elif clause.motion is not None:
            fwd = lft = h = 0.0
            for w in clause.motion.waypoints:
                seconds += math.hypot(w.forward_m - fwd, w.left_m - lft) / clause.motion.speed_mps
                seconds += math.radians(abs(w.heading_deg - h)) / clause.motion.yaw_rate
                fwd, lft, h = w.forward_m, w.left_m, w.heading_deg
        total += max(seconds, clause.min_duration_s)
    return total


def _path_m(program: Program) -> float:
    total = 0.0
    for clause in program.clauses:
        fwd = lft = 0.0
        if isinstance(clause.motion, Curve):
            total += clause.motion.length_m
            continue
        for w in clause.motion.waypoints if clause.motion else ():
            total += math.hypot(w.forward_m - fwd, w.left_m - lft)
            fwd, lft = w.forward_m, w.left_m
    return total


def test_suite_shape() -> None:
    prompts = _suite()
    planned = [p for p in prompts if not p.get("refuse")]
    assert len(prompts) >= 45
    assert sum(1 for p in prompts if p.get("refuse")) >= 6
    assert sum(1 for p in planned if p["expect"]["clauses"] == 3) >= 10
    assert sum(1 for p in planned if p["expect"]["clauses"] == 4) >= 10
    for p in planned:
        assert set(p["expect"]["gestures"]) <= set(GESTURE_NAMES), p["text"]


@pytest.mark.parametrize("entry", _suite(), ids=lambda e: e["text"][:40])
def test_suite_prompt_resolves_as_expected(encoder: SentenceEncoder, entry: dict) -> None:
    if entry.get("refuse"):
        with pytest.raises(PromptRefused):
            _program(entry["text"], encoder)
        return
    program = _program(entry["text"], encoder)
    expect = entry["expect"]
    assert program.typed_clauses == expect["clauses"], describe_program(program)
    fwd, lft, h = end_pose(program.clauses)
    assert (fwd, lft) == pytest.approx((expect["forward_m"], expect["left_m"]), abs=0.01), describe_program(program)
    assert h == pytest.approx(expect["heading_deg"], abs=0.5), describe_program(program)
    detected = {g for c in program.clauses for g in c.gestures}
    assert detected == set(expect["gestures"]), describe_program(program)
    assert _path_m(program) <= 3.0 + 1e-6
    assert _execution_s(program) < 35.0
