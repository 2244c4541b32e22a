"""The grammar: numbers bound to their units, clauses and simultaneous parts, and what it refuses outright."""

from __future__ import annotations

import pytest

from controller.text.grammar import UnknownWords, lex, read, split_clauses
from controller.text.lexicon import LEXICON, Cat
from controller.text.program import PromptRefused


def _quantities(prompt: str) -> list[tuple[str, float]]:
    return [(x.kind, round(x.number or 0.0, 4)) for x in lex(prompt) if x.cat is Cat.QUANTITY]


@pytest.mark.parametrize(
    ("prompt", "quantities"),
    [
        ("walk three steps", [("distance", 0.9)]),
        ("walk a meter and a half", [("distance", 1.5)]),
        ("walk 50 cm then 2 ft", [("distance", 0.5), ("distance", 0.6096)]),
        ("turn 90°", [("angle", 90.0)]),
        ("turn two full turns", [("angle", 720.0)]),
        ("wave twice", [("count", 2.0)]),
        ("wait 1.5 s", [("time", 1.5)]),
        ("walk 2 more meters", [("distance", 2.0)]),
        ("walk at 0.3 m/s", [("speed", 0.3)]),
        ("walk 2 circles", [("shape_count", 2.0)]),
        ("walk three quarters of a metre", [("distance", 0.75)]),
    ],
)
def test_numbers_take_the_unit_after_them(prompt: str, quantities: list[tuple[str, float]]) -> None:
    assert _quantities(prompt) == quantities


def test_a_figure_eight_is_a_shape_not_a_number() -> None:
    lexemes = lex("walk a figure eight")
    assert [x.cat for x in lexemes if x.cat not in (Cat.GRAMMAR, Cat.FILLER)] == [Cat.VERB, Cat.SHAPE]
    assert not any(x.cat in (Cat.NUMBER, Cat.QUANTITY) for x in lexemes)


def test_a_number_without_a_unit_stays_a_number() -> None:
    assert [x.cat for x in lex("turn left 45")][-1] is Cat.NUMBER


def test_the_longest_phrase_wins() -> None:
    cats = [(x.text, x.cat) for x in lex("turn around and come back to the starting point")]
    assert ("turn", Cat.VERB) in cats and ("around", Cat.ANGLE) in cats
    assert ("come back", Cat.VERB) in cats and ("the starting point", Cat.PLACE) in cats


def _clauses(prompt: str) -> list[str]:
    return [c.text for c in read(prompt)]


@pytest.mark.parametrize(
    ("prompt", "clauses"),
    [
        ("walk forward, then turn left. Finally wave!", ["walk forward", "turn left", "wave"]),
        ("step back and turn right", ["step back", "turn right"]),
        ("walk forward 1 m and to the left", ["walk forward 1 m and to the left"]),
        ("walk forward 1 m and back, twice", ["walk forward 1 m and back 2 times"]),
        ("turn right, then left", ["turn right", "turn left"]),
        ("walk 1 m, then 2 m", ["walk 1 m", "walk 2 m"]),
        ("slowly, walk forward", ["walk forward slowly"]),
        ("walk forward while waving", ["walk forward while waving"]),
        ("walk forward waving your left hand", ["walk forward waving your left hand"]),
        ("walk forward and wave at the same time", ["walk forward while wave"]),
        ("raise your arm and, at the same time, wave", ["raise your arm while wave"]),
        ("turn left with both arms raised", ["turn left with both arms raised"]),
    ],
)
def test_clauses(prompt: str, clauses: list[str]) -> None:
    assert _clauses(prompt) == clauses


@pytest.mark.parametrize(
    ("prompt", "parts"),
    [
        ("walk forward while waving", ["walk forward", "waving"]),
        ("walk forward 2 m waving your right hand", ["walk forward 2 m", "waving your right hand"]),
        ("turn left with both arms raised", ["turn left", "both arms raised"]),
        ("wave with your left hand", ["wave with your left hand"]),
        ("keep waving while you turn", ["keep waving", "turn"]),
    ],
)
def test_simultaneous_parts(prompt: str, parts: list[str]) -> None:
    (clause,) = read(prompt)
    assert [p.text for p in clause.parts] == parts


@pytest.mark.parametrize(
    ("prompt", "named"),
    [
        ("walk forward until you reach the wall", '"until"'),
        ("walk forward but stop if someone is there", '"if"'),
        ("once you see the door, wave", '"when"'),
        ("don't wave", '"don\'t"'),
        ("walk forward, no wait, turn left", '"no wait"'),
        ("punch the air", '"punch"'),
        ("jump twice", '"jump"'),
        ("march forward", '"march"'),
        ("nod your head", '"nod"'),
        ("lean to the left", '"lean"'),
        ("wave after you turn", '"after you"'),
        ("follow me", '"follow"'),
    ],
)
def test_refused_outright_with_the_word_named(prompt: str, named: str) -> None:
    with pytest.raises(PromptRefused) as info:
        read(prompt)
    assert named in str(info.value) and "\n" not in str(info.value)


def test_unknown_words_are_named() -> None:
    with pytest.raises(UnknownWords) as info:
        read("walk forward to the blorp with the zibble")
    assert info.value.words == ("blorp", "zibble")


def test_the_lexicon_has_no_phrase_twice_with_different_meanings() -> None:
    assert all(isinstance(k, tuple) and all(k) for k in LEXICON)


def test_a_clause_split_keeps_every_word() -> None:
    lexemes = lex("walk forward two meters, then turn left 90 degrees while waving")
    kept = [x for clause in split_clauses(lexemes) for x in clause]
    assert {x.text for x in lexemes if x.cat not in (Cat.PUNCT, Cat.SEQ)} <= {x.text for x in kept}
