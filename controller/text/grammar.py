"""A typed instruction read into clauses of phrases, every word accounted for.

Three steps, pure functions, no encoder:

1. `lex(prompt)`: normalized text (lower case, numbers as digits) cut into lexemes by
   the longest phrase of the lexicon (`lexicon.py`); a number takes the unit after it
   ("3 steps" is 0.9 m, "twice" 2 times, "2 circles" a count of circles). A word the
   lexicon does not have is an UNKNOWN lexeme.
2. `clauses(lexemes)`: clauses in the order they run, split at sentence ends, "then",
   commas and "and" before an action; each clause split into the parts that run together
   ("while", "as", an -ing verb, "with" before a pose: "turn left with both arms raised").
   A piece without an action (", twice", ", slowly") modifies the clause before it; a
   piece that is only a direction after "then" ("turn right, then left") repeats the verb.
3. `phrase(part)`: the part's behaviour, from its head (a verb; a light verb's noun: "do a
   circle"; a pose: "hands up") with the other lexemes as its arguments, for a handler of
   `behaviours.py` to use. What no handler uses is refused by the handler, by name.

Refusals here: a prompt that corrects itself, a condition on the world ("until", "if"), a
negation, a word for something the robot cannot do, a word the lexicon does not know. Each
is a `PromptRefused` naming the words and the reason.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from controller.text.lexicon import LEXICON, LONGEST, REASONS, UNITS, Cat, Entry, Unit
from controller.text.numbers import words_to_digits
from controller.text.program import PromptRefused

MAX_PROMPT_CHARS = 500
_UNIT_KEYS = {tuple(k.split()): v for k, v in UNITS.items()}
_UNIT_LONGEST = max(len(k) for k in _UNIT_KEYS)
_BETWEEN_NUMBER_AND_UNIT = ("more", "additional", "extra", "full", "complete", "whole")
# A turn given as a bare number after a light verb: "do a 360".
TURN_NUMBERS = (90.0, 180.0, 270.0, 360.0, 540.0, 720.0)


@dataclass(frozen=True)
class Lexeme:
    """One word or phrase of the prompt, as the lexicon reads it."""

    cat: Cat
    text: str  # the words as typed (normalized)
    value: str = ""
    gerund: bool = False
    number: float | None = None  # NUMBER and QUANTITY: the value (a QUANTITY's in metres, seconds, degrees or a count)
    unit: Unit | None = None  # QUANTITY: what it measures

    @property
    def kind(self) -> str:
        """A quantity's kind (distance, time, angle, count, speed, hands, shape_count), else ""."""
        return self.unit.kind if self.unit is not None else ""


@dataclass(frozen=True)
class Part:
    """Lexemes of one clause that run at the same time as its other parts."""

    lexemes: tuple[Lexeme, ...]

    @property
    def text(self) -> str:
        return " ".join(x.text for x in self.lexemes if x.cat is not Cat.PUNCT)


@dataclass(frozen=True)
class ClauseText:
    """One clause: its parts (what runs together) and the words it was read from (normalized)."""

    parts: tuple[Part, ...]
    text: str


_TRANSLATE = str.maketrans({"’": "'", "‘": "'", "“": '"', "”": '"', "—": ",", "–": ",", "\n": " ", "\t": " "})


def normalize(prompt: str) -> str:
    """Lower case, plain quotes, numbers as digits, units apart from numbers, one space between words."""
    text = prompt.lower().translate(_TRANSLATE)
    text = text.replace("°", " degrees ")
    text = re.sub(r"[\"()\[\]{}*_~`]", " ", text)
    text = re.sub(r"(\d)\s*-\s*(?=[a-z])", r"\1 ", text)  # 90-degree
    text = re.sub(r"(\d)\s*(m/s)\b", r"\1 \2", text)
    text = re.sub(r"(\d)([a-z°]+)\b", r"\1 \2", text)  # 2m, 90deg, 3x
    text = re.sub(r"([,;!?]|\.(?!\d))", r" \1 ", text)
    # "once" is a condition before a subject ("once you see"), a sequence in "once that's done", else a count
    text = re.sub(r"\b(?:once|when) (?:that's|that is|you're|you are|it's|it is) (?:done|finished|over)\b", " then ", text)
    text = re.sub(r"\bonce (?=(?:you|someone|somebody|it|the|they|he|she|i|we|there|that|anyone)\b)", "when ", text)
    text = re.sub(r"\b(?:for )?a (?:moment|sec|second or (?:two|so))\b", " for 2 seconds ", text)
    text = re.sub(r"\b(?:for )?a (?:little )?while\b", " for 5 seconds ", text)
    text = re.sub(r"\b(?:three|3) quarters of an? ", " 0.75 ", text)
    text = re.sub(r"\b(?:a|one|1) quarter of an? (?!turn|circle|rotation|spin)", " 0.25 ", text)
    text = re.sub(r"\b(?:a|one|1) third of an? ", " 0.333 ", text)
    text = words_to_digits(text)
    return re.sub(r"\s+", " ", text).strip()


def _tokens(text: str) -> list[str]:
    return re.findall(r"m/s|[a-z0-9']*[a-z][a-z0-9'-]*|\d+(?:\.\d+)?|[,.;!?]", text)


def _is_number(token: str) -> bool:
    return bool(re.fullmatch(r"\d+(?:\.\d+)?", token))


def lex(prompt: str) -> list[Lexeme]:
    """The prompt's lexemes in order (see the module docstring)."""
    tokens = _tokens(normalize(prompt))
    out: list[Lexeme] = []
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if token in ",.;!?":
            out.append(Lexeme(Cat.PUNCT, token, token))
            i += 1
            continue
        if _is_number(token):
            quantity, used = _quantity(tokens, i)
            out.append(quantity)
            i += used
            continue
        entry, used = _longest(tokens, i)
        if entry is None:
            out.append(Lexeme(Cat.UNKNOWN, token))
            i += 1
            continue
        out.append(Lexeme(entry.cat, " ".join(tokens[i : i + used]), entry.value, entry.gerund))
        i += used
    return out


def _longest(tokens: Sequence[str], i: int) -> tuple[Entry | None, int]:
    for n in range(min(LONGEST, len(tokens) - i), 0, -1):
        entry = LEXICON.get(tuple(tokens[i : i + n]))
        if entry is not None:
            return entry, n
    return None, 0


def _quantity(tokens: Sequence[str], i: int) -> tuple[Lexeme, int]:
    """A number at tokens[i] with the unit after it (QUANTITY), or alone (NUMBER); and the tokens used."""
    value = float(tokens[i])
    j = i + 1
    while j < len(tokens) and tokens[j] in _BETWEEN_NUMBER_AND_UNIT:
        j += 1
    for n in range(min(_UNIT_LONGEST, len(tokens) - j), 0, -1):
        unit = _UNIT_KEYS.get(tuple(tokens[j : j + n]))
        if unit is not None:
            return Lexeme(Cat.QUANTITY, " ".join(tokens[i : j + n]), number=value * unit.factor, unit=unit), j + n - i
    return Lexeme(Cat.NUMBER, tokens[i], number=value), 1


# --- clauses and parts ------------------------------------------------------------------------

_NEUTRAL = frozenset({Cat.FILLER, Cat.GRAMMAR, Cat.ORDINAL, Cat.PUNCT})
_MODIFIERS = frozenset({Cat.QUANTITY, Cat.SPEED, Cat.VAGUE, Cat.AGAIN, Cat.NUMBER, Cat.RADIUS, Cat.DIAMETER})
_HEADS = frozenset({Cat.VERB, Cat.LIGHT, Cat.STATE, Cat.REPEAT, Cat.HOLD, Cat.SHAPE, Cat.PLACE, Cat.ANGLE})


def refuse(text: str, reason: str) -> PromptRefused:
    from controller.text.lexicon import CAPABILITIES  # noqa: PLC0415

    return PromptRefused(f'cannot plan "{text}": {reason}; {CAPABILITIES}')


def check_refusals(prompt: str, lexemes: Sequence[Lexeme]) -> None:
    """Refuse what no clause can run: self-corrections, conditions, negations, what the robot cannot do."""
    shown = prompt.strip()
    for cat, key in ((Cat.CORRECTION, "correction"), (Cat.CONDITION, "condition"), (Cat.NEGATION, "negation")):
        found = [x.text for x in lexemes if x.cat is cat]
        if found:
            raise refuse(shown, f'"{found[0]}": {REASONS[key]}')
    for x in lexemes:
        if x.cat is Cat.UNSUPPORTED and x.value != "in_place":
            raise refuse(shown, f'"{x.text}": {REASONS[x.value]}')


def _kind(piece: Sequence[Lexeme]) -> str:
    """ "empty", "modifier" (no action, no direction), "direction" (directions and modifiers) or "action"."""
    cats = [x.cat for x in piece if x.cat not in _NEUTRAL]
    if not cats:
        return "empty"
    if all(c in _MODIFIERS for c in cats):
        return "modifier"
    if all(c in _MODIFIERS or c is Cat.DIR for c in cats):
        return "direction"
    return "action"


def _amount(piece: Sequence[Lexeme]) -> bool:
    """The piece states how far or how much to turn ("then 2 m"): after "then" that is a clause of its own."""
    return any(x.cat is Cat.QUANTITY and x.kind in ("distance", "angle") for x in piece)


def _strip_leading(piece: list[Lexeme]) -> list[Lexeme]:
    while piece and piece[0].cat in (Cat.FILLER, Cat.ORDINAL, Cat.PUNCT, Cat.AND, Cat.SEQ):
        piece = piece[1:]
    return piece


def _starts_simultaneous(piece: Sequence[Lexeme]) -> bool:
    content = [x for x in piece if x.cat not in (Cat.FILLER, Cat.PUNCT)]
    if not content:
        return False
    first = content[0]
    return first.cat is Cat.SIM or (first.cat in (Cat.VERB, Cat.LIGHT) and first.gerund) or _body_state_at(content, 0)


def _body_state_at(piece: Sequence[Lexeme], i: int) -> bool:
    """A pose named without a verb from lexeme i: "(with) both arms raised", "hands up", "arms crossed"."""
    j = i + 1 if i < len(piece) and piece[i].text == "with" else i
    while j < len(piece) and piece[j].cat in (Cat.GRAMMAR, Cat.HANDS, Cat.DIR, Cat.FILLER) and piece[j].text not in ("to",):
        j += 1
    if j < len(piece) and (piece[j].cat is Cat.BODY or piece[j].kind == "hands"):
        k = j + 1
        while k < len(piece) and piece[k].cat in (Cat.GRAMMAR, Cat.FILLER):
            k += 1
        return k < len(piece) and piece[k].cat is Cat.STATE
    return False


def _pieces(lexemes: Sequence[Lexeme]) -> list[tuple[str, list[Lexeme]]]:
    """(delimiter before it, piece) for each piece between sentence ends, "then"s, commas and "and"s."""
    out: list[tuple[str, list[Lexeme]]] = []
    current: list[Lexeme] = []
    delimiter = "start"
    for x in lexemes:
        if x.cat is Cat.PUNCT and x.text in ".;!?":
            out.append((delimiter, current))
            current, delimiter = [], "sentence"
        elif x.cat is Cat.SEQ:
            out.append((delimiter, current))
            current, delimiter = [], "then"
        elif x.cat is Cat.PUNCT:
            out.append((delimiter, current))
            current, delimiter = [], ","
        elif x.cat is Cat.AND:
            out.append((delimiter, current))
            current, delimiter = [], "and"
        else:
            current.append(x)
    out.append((delimiter, current))
    return out


def split_clauses(lexemes: Sequence[Lexeme]) -> list[list[Lexeme]]:
    """The clauses in order, each a list of lexemes (see the module docstring for the rules)."""
    clauses: list[list[Lexeme]] = []
    pending: list[Lexeme] = []  # modifiers before any clause ("slowly, walk forward")
    join_next = False  # "raise your arm and, at the same time, wave": the piece after joins the clause before
    for delimiter, raw in _pieces(lexemes):
        piece = _strip_leading(list(raw))
        kind = _kind(piece)
        if kind == "empty":
            continue
        if all(x.cat in (Cat.SIM, *_NEUTRAL) for x in piece):
            join_next = bool(clauses)
            continue
        if join_next:
            join_next = False
            clauses[-1] += [Lexeme(Cat.SIM, "while"), *piece]
            continue
        simultaneous_end = any(x.cat is Cat.SIM and x.text in ("at the same time", "simultaneously") for x in piece[-1:])
        if clauses and delimiter == "and" and simultaneous_end:
            clauses[-1] += [Lexeme(Cat.SIM, "while"), *piece[:-1]]  # "walk forward and wave at the same time"
        elif clauses and kind == "modifier" and delimiter in ("then", "sentence") and _amount(piece):
            verb = next((x for x in clauses[-1] if x.cat in (Cat.VERB, Cat.LIGHT)), None)
            clauses.append(([verb] if verb is not None else []) + piece)  # "walk 1 m, then 2 m": another walk
        elif clauses and kind == "modifier":
            clauses[-1] += piece
        elif clauses and kind == "direction" and delimiter == "and":
            clauses[-1] += [Lexeme(Cat.AND, "and"), *piece]  # "forward and to the left", "half a meter and back"
        elif clauses and kind == "direction" and delimiter == "," and any(x.cat is Cat.SHAPE for x in clauses[-1]):
            clauses[-1] += piece  # "walk a figure eight, starting to the right": the side of the path
        elif clauses and kind == "direction":
            verb = next((x for x in clauses[-1] if x.cat in (Cat.VERB, Cat.LIGHT)), None)
            clauses.append(([verb] if verb is not None else []) + piece)  # "turn right, then left"
        elif clauses and delimiter in (",", "and") and _starts_simultaneous(piece) and not _sequence_after_and(delimiter, piece):
            clauses[-1] += [Lexeme(Cat.SIM, "while"), *piece]
        elif kind == "modifier":
            pending += piece
        else:
            clauses.append(piece + pending)
            pending = []
    if pending and clauses:
        clauses[-1] += pending
    elif pending:
        clauses.append(pending)
    return clauses


def _sequence_after_and(delimiter: str, piece: Sequence[Lexeme]) -> bool:
    """ "walk forward and waving" is odd but simultaneous; "..., and raising" too. Only a SIM word or -ing joins after "and"."""
    return delimiter == "and" and not (piece[0].cat is Cat.SIM or piece[0].gerund or _body_state_at(piece, 0))


def split_parts(clause: Sequence[Lexeme]) -> list[Part]:
    """The simultaneous parts of one clause: split at "while"/"as", at an -ing verb after the head, at "with" before a pose."""
    parts: list[list[Lexeme]] = [[]]
    for i, x in enumerate(clause):
        current = parts[-1]
        has_head = any(y.cat in _HEADS for y in current)
        keeps = bool(current) and current[-1].cat is Cat.VERB and current[-1].value == "hold"  # "keep walking", "keep waving"
        if x.cat is Cat.SIM:
            parts.append([])
            continue
        if has_head and not keeps and x.cat in (Cat.VERB, Cat.LIGHT) and x.gerund:
            parts.append([x])
            continue
        if has_head and x.text == "with" and _body_state_at(clause, i) and not _gesture_head(current):
            parts.append([])
            continue
        current.append(x)
    return [Part(tuple(p)) for p in parts if _kind(p) != "empty"]


def _gesture_head(lexemes: Sequence[Lexeme]) -> bool:
    """The part's head is a gesture verb ("wave with your right hand": "with" belongs to it)."""
    head = next((x for x in lexemes if x.cat is Cat.VERB), None)
    return head is not None and head.value in ("wave", "raise", "point", "reach", "arms_crossed", "lower", "put", "hold")


def read(prompt: str) -> list[ClauseText]:
    """The prompt's clauses, each with its simultaneous parts; PromptRefused for what cannot run at all."""
    lexemes = lex(prompt)
    check_refusals(prompt, lexemes)
    unknown = [x.text for x in lexemes if x.cat is Cat.UNKNOWN]
    if unknown:
        raise UnknownWords(prompt.strip(), tuple(dict.fromkeys(unknown)))
    return [ClauseText(tuple(split_parts(c)), " ".join(x.text for x in c if x.cat is not Cat.PUNCT)) for c in split_clauses(lexemes)]


class UnknownWords(PromptRefused):
    """Words the lexicon does not have; the resolver explains them (the encoder names what they are closest to)."""

    def __init__(self, prompt: str, words: tuple[str, ...]) -> None:
        self.prompt = prompt
        self.words = words
        quoted = ", ".join(f'"{w}"' for w in words)
        super().__init__(f'cannot plan "{prompt}": {quoted} {"is not a word" if len(words) == 1 else "are not words"} it can act on')
