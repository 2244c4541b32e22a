"""Clauses resolved to behaviours with the real sentence encoder; refusals; the prompt suite's expectations."""

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
from controller.text.program import DETECTED_GESTURES, Program, PromptRefused
from controller.text.resolve import (
    PROTOTYPES,
    SIMILARITY_THRESHOLD,
    SUPPORTED,
    classify_action,
    describe_program,
    end_pose,
    nearest_behaviours,
    plan_program,
)

SUITE = Path(__file__).resolve().parents[3] / "configs" / "prompts" / "suite.yaml"


@pytest.fixture(scope="module")
def encoder(assets: Assets) -> SentenceEncoder:
    return SentenceEncoder.load(assets)


class OrthogonalEncoder:
    """A stand-in that knows no phrase: every text gets its own direction, so only keywords decide."""

    def __init__(self) -> None:
        self.seen: dict[str, int] = {}

    def embed(self, texts: Sequence[str]) -> NDArray[np.float32]:
        out = np.zeros((len(texts), 4096), dtype=np.float32)
        for i, t in enumerate(texts):
            out[i, self.seen.setdefault(t, len(self.seen))] = 1.0
        return out


# --- paraphrases land on the right behaviour (the encoder path: keywords are bypassed) ---

PARAPHRASES = {
    "walk": ["stroll ahead", "advance", "head forward", "move ahead", "step forward", "go", "shuffle backwards", "make your way forward",
             "proceed ahead", "get moving forward", "scoot over to the left"],
    "turn": ["spin", "rotate", "pivot", "swivel around", "do a full rotation", "spin on the spot", "face the opposite direction",
             "turn yourself around", "twirl"],
    "wave": ["greet us with your hand", "wave hi", "give us a wave", "say hello with your hand", "greet the audience"],
    "raise": ["put your hands in the air", "lift both arms", "throw your hands up", "arms in the air", "put your arms up high"],
    "point": ["point your finger", "point straight ahead"],
    "reach": ["reach out in front of you", "stretch out your arm"],
    "arms_crossed": ["fold your arms across your chest", "cross both arms"],
    "hands_on_hips": ["place your hands on your hips"],
    "wait": ["hold on a second", "stay where you are", "stay still", "keep still", "remain still"],
    "return": ["head back to where you began", "return to your starting spot", "get back to the beginning"],
}  # fmt: skip
NONSENSE = ["asdf qwerty", "the quick brown fox", "purple monkey dishwasher", "lorem ipsum dolor", "what is the weather", "xyzzy",
            "it is raining today", "the cat sat", "meow", "how are you"]  # fmt: skip
UNSUPPORTED = ["do a backflip", "sprint to the wall", "sit on the floor", "lie down on the ground", "crawl under the table",
               "kick the ball", "climb up the stairs", "pick up the cup", "open the door", "swim across", "do ten push ups"]  # fmt: skip


@pytest.mark.parametrize(("behaviour", "phrase"), [(b, p) for b, ps in PARAPHRASES.items() for p in ps])
def test_paraphrase_lands_on_its_behaviour(encoder: SentenceEncoder, behaviour: str, phrase: str) -> None:
    best = nearest_behaviours(phrase, encoder, k=1)[0]
    assert best.behaviour == behaviour, best
    assert best.score >= SIMILARITY_THRESHOLD


@pytest.mark.parametrize("phrase", NONSENSE)
def test_nonsense_is_below_the_threshold_or_unsupported(encoder: SentenceEncoder, phrase: str) -> None:
    best = nearest_behaviours(phrase, encoder, k=1)[0]
    assert best.score < SIMILARITY_THRESHOLD or best.behaviour not in SUPPORTED, best
    assert not classify_action(phrase, encoder).supported


@pytest.mark.parametrize("phrase", UNSUPPORTED)
def test_unsupported_requests_land_on_a_refusal_prototype(encoder: SentenceEncoder, phrase: str) -> None:
    assert nearest_behaviours(phrase, encoder, k=1)[0].behaviour not in SUPPORTED
    assert not classify_action(phrase, encoder).supported


def test_threshold_separates_the_calibration_sets(encoder: SentenceEncoder) -> None:
    """Calibration figures: the lowest correct paraphrase score and the highest nonsense score landing on a behaviour."""
    correct = [nearest_behaviours(p, encoder, k=1)[0].score for ps in PARAPHRASES.values() for p in ps]
    wrong = [m.score for m in (nearest_behaviours(p, encoder, k=1)[0] for p in NONSENSE) if m.behaviour in SUPPORTED]
    assert min(correct) > SIMILARITY_THRESHOLD > max(wrong, default=0.0)
    assert min(correct) - SIMILARITY_THRESHOLD >= 0.01 and SIMILARITY_THRESHOLD - max(wrong, default=0.0) >= 0.01


def test_every_behaviour_has_prototypes() -> None:
    assert set(SUPPORTED) <= set(PROTOTYPES)
    assert all(PROTOTYPES[b] for b in PROTOTYPES)


# --- resolution ---


def _program(prompt: str, encoder: object) -> Program:
    return plan_program(prompt, encoder)  # type: ignore[arg-type]


def test_the_example_prompt(encoder: SentenceEncoder) -> None:
    p = _program("walk forward two meters, then turn left 90 degrees, then wave with your right hand", encoder)
    assert [c.text for c in p.clauses] == ["walk forward 2 meters", "turn left 90 degrees", "wave with your right hand"]
    walk, turn, wave = p.clauses
    assert walk.motion is not None and walk.displacement == (2.0, 0.0, 0.0) and walk.motion.speed_mps == 0.5
    assert walk.quantities["distance_m"] == 2.0 and walk.quantities["direction"] == "forward"
    assert turn.displacement == (0.0, 0.0, 90.0)
    assert wave.motion is None and wave.gestures == ("wave_right",) and wave.min_duration_s == 3.0


def test_polite_prompt_back_a_little_then_spin(encoder: SentenceEncoder) -> None:
    p = _program("Could you please go back a little and then spin around?", encoder)
    assert [c.displacement for c in p.clauses] == [(-0.5, 0.0, 0.0), (0.0, 0.0, 360.0)]
    spin = p.clauses[1].motion
    assert spin is not None and [w.heading_deg for w in spin.waypoints] == [120.0, 240.0, 360.0]


@pytest.mark.parametrize(
    ("prompt", "speed", "forward"),
    [("walk forward slowly", 0.3, 1.0), ("walk forward quickly for 3 seconds", 0.8, 2.4), ("walk forward for 3 seconds", 0.5, 1.5)],
)
def test_speed_and_time(encoder: SentenceEncoder, prompt: str, speed: float, forward: float) -> None:
    (clause,) = _program(prompt, encoder).clauses
    assert clause.motion is not None and clause.motion.speed_mps == speed
    assert clause.displacement[0] == pytest.approx(forward)


def test_large_turns_are_split_the_intended_way(encoder: SentenceEncoder) -> None:
    (clause,) = _program("turn right 180 degrees", encoder).clauses
    assert clause.motion is not None and [w.heading_deg for w in clause.motion.waypoints] == [-90.0, -180.0]
    (clause,) = _program("turn left 150 degrees", encoder).clauses
    assert clause.motion is not None and len(clause.motion.waypoints) == 1


def test_circle_to_the_left_and_right(encoder: SentenceEncoder) -> None:
    (left,) = _program("walk in a circle", encoder).clauses
    (right,) = _program("walk in a circle to the right", encoder).clauses
    assert left.motion is not None and len(left.motion.waypoints) == 8
    assert max(w.left_m for w in left.motion.waypoints) == pytest.approx(1.5)
    assert right.motion is not None and min(w.left_m for w in right.motion.waypoints) == pytest.approx(-1.5)
    assert left.displacement == pytest.approx((0.0, 0.0, 360.0), abs=1e-9)


def test_come_back_composes_earlier_clauses(encoder: SentenceEncoder) -> None:
    p = _program("walk forward two meters, turn left, walk one meter, then come back to where you started", encoder)
    fwd, lft, _ = end_pose(p.clauses)
    assert math.hypot(fwd, lft) < 1e-9
    back = p.clauses[-1].motion
    assert back is not None and back.waypoints[0].forward_m == 0.0  # turns to face the start before walking


def test_there_and_back_repeated(encoder: SentenceEncoder) -> None:
    (clause,) = _program("walk forward one meter and back, twice", encoder).clauses
    assert clause.motion is not None
    assert [c for w in clause.motion.waypoints for c in (w.forward_m, w.left_m)] == pytest.approx([1, 0, 0, 0, 1, 0, 0, 0])
    assert clause.quantities["repetitions"] == 2


@pytest.mark.parametrize(
    ("prompt", "gestures", "seconds"),
    [
        ("wave", ("wave_right",), 3.0),
        ("wave with both hands", ("wave_both",), 3.0),
        ("wave three times", ("wave_right",), 2.5),
        ("wave with your left hand for 5 seconds", ("wave_left",), 5.0),
        ("raise your left arm", ("raise_left",), 3.0),
        ("hands up", ("raise_both",), 3.0),
        ("raise your arms", ("raise_both",), 3.0),
        ("point", ("point",), 3.0),
        ("reach forward", ("reach",), 3.0),
        ("cross your arms", ("arms_crossed",), 3.0),
        ("put your hands on your hips", ("hands_on_hips",), 3.0),
        ("greet us with your hand", ("wave_right",), 3.0),
        ("put your hands in the air", ("raise_both",), 3.0),
    ],
)
def test_gestures_in_place(encoder: SentenceEncoder, prompt: str, gestures: tuple[str, ...], seconds: float) -> None:
    (clause,) = _program(prompt, encoder).clauses
    assert clause.motion is None and clause.gestures == gestures and clause.min_duration_s == pytest.approx(seconds)


@pytest.mark.parametrize(
    ("prompt", "gestures"),
    [
        ("walk forward while waving", ("wave_right",)),
        ("wave as you walk", ("wave_right",)),
        ("walk forward waving your left hand", ("wave_left",)),
        ("turn left with both arms raised", ("raise_both",)),
    ],
)
def test_gestures_on_top_of_motion(encoder: SentenceEncoder, prompt: str, gestures: tuple[str, ...]) -> None:
    (clause,) = _program(prompt, encoder).clauses
    assert clause.motion is not None and clause.gestures == gestures


@pytest.mark.parametrize(("prompt", "seconds"), [("wait for 3 seconds", 3.0), ("pause", 2.0), ("stand still for five seconds", 5.0)])
def test_waiting(encoder: SentenceEncoder, prompt: str, seconds: float) -> None:
    (clause,) = _program(prompt, encoder).clauses
    assert clause.motion is None and clause.gestures == () and clause.min_duration_s == seconds


@pytest.mark.parametrize(
    ("prompt", "behaviour"),
    [
        ("stroll ahead two meters", "walk"),
        ("advance one meter", "walk"),
        ("head forward", "walk"),
        ("move ahead", "walk"),
        ("step forward", "walk"),
        ("go", "walk"),
        ("spin", "turn"),
        ("rotate to the right", "turn"),
        ("pivot left", "turn"),
        ("stay where you are", "wait"),
    ],
)
def test_paraphrased_prompts_plan(encoder: SentenceEncoder, prompt: str, behaviour: str) -> None:
    (clause,) = _program(prompt, encoder).clauses
    assert clause.quantities["behaviour"] == behaviour


def test_bare_go_back_returns_to_the_start(encoder: SentenceEncoder) -> None:
    p = _program("walk forward 2 meters, turn left, walk forward one meter, then go back", encoder)
    assert p.clauses[-1].quantities["behaviour"] == "return"
    assert math.hypot(*end_pose(p.clauses)[:2]) < 1e-9
    (alone,) = _program("go back", encoder).clauses  # nothing to return from: a backward walk
    assert alone.displacement == (-1.0, 0.0, 0.0)
    (measured,) = _program("go back two meters", encoder).clauses
    assert measured.displacement == (-2.0, 0.0, 0.0)
    _walk, step = _program("walk forward a meter, then step back", encoder).clauses  # one step, not a return
    assert step.quantities["behaviour"] == "walk" and step.displacement == pytest.approx((-0.3, 0.0, 0.0))


def test_hold_it_keeps_the_gesture_and_lowering_the_arms_is_a_short_stand(encoder: SentenceEncoder) -> None:
    raise_, hold, lower = _program("raise your right hand, hold it for 4 seconds, then lower your arms", encoder).clauses
    assert raise_.gestures == hold.gestures == ("raise_right",) and hold.min_duration_s == 4.0
    assert lower.gestures == () and lower.motion is None and lower.min_duration_s == 1.0


@pytest.mark.parametrize("prompt", ["raise your right hand, then lower it", "raise both arms and then put them down"])
def test_lowering_it_after_a_gesture_is_a_short_stand(encoder: SentenceEncoder, prompt: str) -> None:
    raised, lowered = _program(prompt, encoder).clauses
    assert raised.gestures and lowered.gestures == () and lowered.motion is None and lowered.min_duration_s == 1.0


def test_legs_with_their_own_distances_and_a_stated_speed(encoder: SentenceEncoder) -> None:
    (clause,) = _program("walk 2 m forward and 1 m backward at 0.4 meters per second", encoder).clauses
    assert clause.motion is not None and clause.motion.speed_mps == 0.4
    assert [w.forward_m for w in clause.motion.waypoints] == [2.0, 1.0]


def test_robot_is_a_name_only_when_addressed(encoder: SentenceEncoder) -> None:
    assert [c.text for c in _program("Robot, walk forward, then turn left", encoder).clauses] == ["walk forward", "turn left"]
    with pytest.raises(PromptRefused, match='"do the robot"'):
        _program("do the robot", encoder)


def test_do_it_again_repeats_the_previous_clause(encoder: SentenceEncoder) -> None:
    p = _program("turn left 45 degrees, then do it again twice", encoder)
    assert end_pose(p.clauses) == pytest.approx((0.0, 0.0, 135.0))


# --- refusals ---


@pytest.mark.parametrize(
    ("prompt", "named"),
    [
        ("please do a backflip", '"do a backflip"'),
        ("walk forward one meter and then sit down", '"sit down"'),
        ("walk 500 meters", '"walk 500 meters"'),
        ("turn 5000 degrees", '"turn 5000 degrees"'),
        ("wait for -3 seconds", "wait for -3 seconds"),
        ("wait 0 seconds", "wait 0 seconds"),
        ("asdf qwerty", '"asdf qwerty"'),
        ("walk to the kitchen", '"walk to the kitchen"'),
        ("jump", '"jump"'),
        ("run forward", '"run forward"'),
        ("lie down", '"lie down"'),
        ("crawl", '"crawl"'),
        ("kick the ball", '"kick the ball"'),
        ("climb the stairs", '"climb the stairs"'),
        ("dance", '"dance"'),
        ("pick up the box", '"pick up the box"'),
        ("open the door", '"open the door"'),
        ("fly", '"fly"'),
        ("swim", '"swim"'),
        ("walk forward while clapping", '"clapping"'),
        ("wave your right hand while raising your right arm", "one gesture per arm"),
        ("walk forward while turning left", "one movement at a time"),
        ("wave 100 times", "repetitions"),
        ("do it again", "nothing before it"),
        ("lift your left arm, no wait, the right one", "corrects itself"),
        ("walk forward until you hit the wall", "when to stop"),
        ("walk over to the window", "cannot see"),
        ("walk like a zombie", "styles"),
        ("march in place", "in place"),
        ("turn your head left", "head"),
        ("walk three meters forward then five more", "no unit"),
        ("walk forward 1 meter at 3 meters per second", "3 m/s"),
        ("make a circle with your arms", "only gestures"),
    ],
)
def test_refusals_name_the_part_in_one_line(encoder: SentenceEncoder, prompt: str, named: str) -> None:
    with pytest.raises(PromptRefused) as info:
        _program(prompt, encoder)
    message = str(info.value)
    assert named in message and "\n" not in message
    assert message.startswith("cannot plan") and "it can walk" in message


@pytest.mark.parametrize("prompt", ["", "   ", "walk forward " * 40])
def test_empty_and_too_long_prompts_are_refused(encoder: SentenceEncoder, prompt: str) -> None:
    with pytest.raises(PromptRefused, match="cannot plan"):
        _program(prompt, encoder)


def test_refusal_is_also_a_value_error(encoder: SentenceEncoder) -> None:
    with pytest.raises(ValueError, match="flips"):
        _program("do a backflip", encoder)


def test_keywords_plan_without_an_encoder_that_knows_anything() -> None:
    p = _program("walk forward two meters, then turn left, then wave with both hands", OrthogonalEncoder())
    assert end_pose(p.clauses) == pytest.approx((2.0, 0.0, 90.0))
    with pytest.raises(PromptRefused, match="not an action"):
        _program("make your way forward", OrthogonalEncoder())


def test_describe_program_has_one_line_per_clause(encoder: SentenceEncoder) -> None:
    p = _program("walk forward two meters, then turn left 90 degrees, then wave with your right hand", encoder)
    lines = describe_program(p).splitlines()
    assert len(lines) == 4 and lines[0].startswith('1. "walk forward 2 meters"')
    assert "distance_m=2" in lines[0] and "+2.00 m fwd" in lines[0]
    assert "wave_right" in lines[2] and "3.0 s" in lines[2]
    assert lines[3].startswith("total: +2.00 m fwd +0.00 m left +90 deg")


# --- the prompt suite ---


def _suite() -> list[dict]:
    return yaml.safe_load(SUITE.read_text())["prompts"]


def _execution_s(program: Program) -> float:
    """A rough duration at the planned speeds: path / speed + turning / rate, at least each clause's minimum."""
    total = 0.0
    for clause in program.clauses:
        seconds = 0.0
        if clause.motion is not None:
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
        assert set(p["expect"]["gestures"]) <= set(DETECTED_GESTURES), p["text"]


@pytest.mark.parametrize("entry", _suite(), ids=lambda e: e["text"][:40])
def test_suite_prompt_resolves_as_expected(encoder: SentenceEncoder, entry: dict) -> None:
    if entry.get("refuse"):
        with pytest.raises(PromptRefused):
            _program(entry["text"], encoder)
        return
    program = _program(entry["text"], encoder)
    expect = entry["expect"]
    assert len(program.clauses) == expect["clauses"], describe_program(program)
    fwd, lft, h = end_pose(program.clauses)
    assert (fwd, lft) == pytest.approx((expect["forward_m"], expect["left_m"]), abs=0.01), describe_program(program)
    assert h == pytest.approx(expect["heading_deg"], abs=0.5), describe_program(program)
    detected = {g for c in program.clauses for g in c.gestures if g in DETECTED_GESTURES}
    assert detected == set(expect["gestures"]), describe_program(program)
    assert _path_m(program) <= 3.0 + 1e-6
    assert _execution_s(program) < 35.0
