"""Prompts split into clauses and simultaneous parts; quantities and word numbers read (pure text, no encoder)."""

from __future__ import annotations

import pytest

from controller.text.decompose import STEP_M, action_phrase, normalize, read_quantities, split_clauses, split_parts
from controller.text.numbers import words_to_digits


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("walk two meters", "walk 2 meters"),
        ("twenty five degrees", "25 degrees"),
        ("twenty-five steps", "25 steps"),
        ("one and a half meters", "1.5 meters"),
        ("two and a half meters", "2.5 meters"),
        ("half a meter", "0.5 meter"),
        ("a meter", "1 meter"),
        ("a meter and a half", "1.5 meter"),
        ("two meters and a half", "2.5 meters"),
        ("one hundred and twenty degrees", "120 degrees"),
        ("a hundred degrees", "100 degrees"),
        ("five hundred meters", "500 meters"),
        ("nine hundred ninety nine", "999"),
        ("forty two", "42"),
        ("a few steps", "3 steps"),
        ("a couple of steps", "2 steps"),
        ("one point five meters", "1.5 meters"),
        ("1/2 meter", "0.5 meter"),
        ("wave twice", "wave 2 times"),
        ("turn once", "turn 1 times"),
        ("x3", "3 times"),
        ("a second", "1 second"),
        ("a half turn", "a half turn"),  # turns stay words: the quantity patterns read them
        ("half a turn", "half a turn"),
        ("walk forward", "walk forward"),
    ],
)
def test_word_numbers(text: str, expected: str) -> None:
    assert words_to_digits(text) == expected


@pytest.mark.parametrize(
    ("prompt", "clauses"),
    [
        (
            "walk forward two meters, then turn left 90 degrees, then wave with your right hand",
            ["walk forward 2 meters", "turn left 90 degrees", "wave with your right hand"],
        ),
        ("Could you please go back a little and then spin around?", ["go back a little", "spin around"]),
        ("walk forward and turn left", ["walk forward", "turn left"]),
        ("walk forward and to the left", ["walk forward and to the left"]),
        ("walk forward one meter and back, twice", ["walk forward 1 meter and back, 2 times"]),
        ("First, walk forward. Then turn right, then left.", ["walk forward", "turn right", "turn left"]),
        ("walk forward; turn left! wave", ["walk forward", "turn left", "wave"]),
        ("walk forward. after that turn left. afterwards wave. next raise your arms. finally stop",
         ["walk forward", "turn left", "wave", "raise your arms", "stop"]),
        ("first walk forward, and then turn around", ["walk forward", "turn around"]),
        ("walk 1.5 meters. turn left", ["walk 1.5 meters", "turn left"]),
        ("slowly, walk back 2 steps", ["walk back 2 steps slowly"]),
        ("walk forward and wave at the same time", ["walk forward while wave"]),
        ("walk forward, waving your left hand", ["walk forward waving your left hand"]),
        ("turn right, then left, then wave", ["turn right", "turn left", "wave"]),
        ("walk forward followed by a turn to the left", ["walk forward", "a turn to the left"]),
        ("walk forward a meter, then step back", ["walk forward 1 meter", "step back"]),
        ("do a 360, then wave", ["turn 360 degrees", "wave"]),
        ("walk forward a meter, then back two steps", ["walk forward 1 meter", "walk back 2 steps"]),
    ],
)  # fmt: skip
def test_split_clauses(prompt: str, clauses: list[str]) -> None:
    assert split_clauses(prompt) == clauses


@pytest.mark.parametrize(
    "prompt",
    [
        "please walk forward",
        "Could you walk forward?",
        "can you please walk forward",
        "I'd like you to walk forward",
        "I would like you to walk forward.",
        "go ahead and walk forward",
        "now walk forward",
        "Robot, walk forward!",
        "hey robot, just walk forward for me, thanks",
        "Would you kindly walk forward",
    ],
)
def test_politeness_and_filler_are_ignored(prompt: str) -> None:
    assert split_clauses(prompt) == ["walk forward"]


@pytest.mark.parametrize(
    ("clause", "parts"),
    [
        ("walk forward while waving", ["walk forward", "waving"]),
        ("wave as you walk", ["wave", "walk"]),
        ("walk forward waving your left hand", ["walk forward", "waving your left hand"]),
        ("turn left with both arms raised", ["turn left", "both arms raised"]),
        ("walk forward with your hands up", ["walk forward", "your hands up"]),
        ("wave with your right hand", ["wave with your right hand"]),  # "with" inside one gesture
        ("walk forward", ["walk forward"]),
        ("go to the starting point", ["go to the starting point"]),  # not a gerund
        ("walk 2 meters while you wave with both hands", ["walk 2 meters", "wave with both hands"]),
    ],
)
def test_simultaneous_parts_stay_in_one_clause(clause: str, parts: list[str]) -> None:
    assert split_clauses(clause) == [clause]
    assert split_parts(clause) == parts


@pytest.mark.parametrize(
    ("text", "metres"),
    [
        ("walk 2 m", 2.0),
        ("walk 2m", 2.0),
        ("walk two meters", 2.0),
        ("walk 1 metre", 1.0),
        ("walk 50 cm", 0.5),
        ("walk fifty centimeters", 0.5),
        ("walk 6 feet", 1.8288),
        ("walk one foot", 0.3048),
        ("take 3 steps", 3 * STEP_M),
        ("take a step", STEP_M),
        ("take a few steps", 3 * STEP_M),
        ("walk one and a half meters", 1.5),
        ("walk half a meter", 0.5),
        ("walk a meter", 1.0),
        ("walk twenty five centimeters", 0.25),
    ],
)
def test_distances(text: str, metres: float) -> None:
    q = read_quantities(normalize(text))
    assert q.distance_m == pytest.approx(metres, abs=1e-4)


@pytest.mark.parametrize(
    ("text", "degrees"),
    [
        ("turn left 90 degrees", 90),
        ("turn left 90°", 90),
        ("turn 45 deg", 45),
        ("turn ninety degrees", 90),
        ("a 90-degree turn", 90),
        ("do a quarter turn", 90),
        ("do a half turn", 180),
        ("turn half a turn", 180),
        ("turn around", 180),
        ("about face", 180),
        ("about-face", 180),
        ("make a u-turn", 180),
        ("do a full circle", 360),
        ("do a full turn", 360),
        ("turn all the way around", 360),
        ("do two full turns", 720),
    ],
)
def test_turn_angles(text: str, degrees: float) -> None:
    assert read_quantities(normalize(text)).turn_deg == degrees


@pytest.mark.parametrize(
    ("text", "seconds"),
    [
        ("wait 3 seconds", 3.0),
        ("wait three secs", 3.0),
        ("wait 3 s", 3.0),
        ("pause for a second", 1.0),
        ("stand still for two minutes", 120.0),
        ("wave for five seconds", 5.0),
        ("wait a moment", 2.0),
    ],
)
def test_durations(text: str, seconds: float) -> None:
    assert read_quantities(normalize(text)).duration_s == seconds


@pytest.mark.parametrize(
    ("text", "times"),
    [("wave three times", 3), ("wave twice", 2), ("wave x3", 3), ("turn left once", 1), ("walk forward, thrice", 3)],
)
def test_repetitions(text: str, times: int) -> None:
    assert read_quantities(normalize(text)).repetitions == times


@pytest.mark.parametrize(
    ("text", "directions"),
    [
        ("walk forward", ("forward",)),
        ("go ahead", ("forward",)),
        ("go straight", ("forward",)),
        ("walk backward", ("backward",)),
        ("go back", ("backward",)),
        ("walk backwards", ("backward",)),
        ("step sideways", ("sideways",)),
        ("move to the left", ("left",)),
        ("walk forward and to the right", ("forward", "right")),
    ],
)
def test_directions(text: str, directions: tuple[str, ...]) -> None:
    assert read_quantities(normalize(text)).directions == directions


@pytest.mark.parametrize(
    ("text", "speed"),
    [
        ("walk slowly", "slow"),
        ("walk carefully", "slow"),
        ("walk slow", "slow"),
        ("walk fast", "fast"),
        ("walk quickly", "fast"),
        ("walk briskly", "fast"),
        ("walk as fast as you can", "fast"),
        ("walk", None),
    ],
)
def test_speed_words(text: str, speed: str | None) -> None:
    assert read_quantities(normalize(text)).speed == speed


@pytest.mark.parametrize(
    ("text", "hand"),
    [
        ("wave with your left hand", "left"),
        ("wave with your right hand", "right"),
        ("wave with both hands", "both"),
        ("raise your arms", "both"),
        ("hands up", "both"),
        ("wave", None),
    ],
)
def test_hands(text: str, hand: str | None) -> None:
    assert read_quantities(normalize(text)).hand == hand


def test_vague_and_negative_amounts_are_flagged() -> None:
    assert read_quantities(normalize("go back a little")).vague
    assert read_quantities(normalize("turn a bit to the left")).vague
    assert read_quantities(normalize("wait -3 seconds")).negative
    assert read_quantities(normalize("wait minus three seconds")).negative
    assert not read_quantities(normalize("walk 2 meters")).negative


def test_separate_distances_per_direction() -> None:
    q = read_quantities(normalize("walk one meter forward and two meters to the left"))
    assert q.distances == (("forward", 1.0), ("left", 2.0))


def test_a_bare_number_is_kept_for_the_resolver() -> None:
    assert read_quantities(normalize("turn left 90")).bare_number == 90
    assert read_quantities(normalize("turn left 90 degrees")).bare_number is None


def test_action_phrase_drops_quantities() -> None:
    assert action_phrase(normalize("stroll ahead two meters")) == "stroll ahead"
    assert action_phrase(normalize("wave three times")) == "wave"
    assert action_phrase(normalize("walk forward for 3 seconds")) == "walk forward"


def test_quantities_as_dict_leave_out_what_was_not_said() -> None:
    d = read_quantities(normalize("walk forward two meters slowly")).as_dict()
    assert d == {"distance_m": 2.0, "direction": "forward", "speed": "slow"}
