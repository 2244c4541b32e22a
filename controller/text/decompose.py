"""A typed instruction split into ordered clauses, and the quantities each clause states.

Pure text work, no encoder: `split_clauses(prompt)` gives the clauses in order (what runs one
after the other), `split_parts(clause)` the simultaneous parts of one clause ("walk forward
while waving" -> "walk forward", "waving"), `read_quantities(text)` what a part says about
distance, direction, turning, speed, time, hands and repetitions.

Splitting: sentences (". ! ? ;"), commas, "then", "and then", "after that", "afterwards",
"next", "finally", "followed by"; "and" splits only when an action follows it ("walk forward
and turn left"), not inside one action ("forward and to the left", "one meter and back").
A piece that holds no action is a modifier of the clause before it ("..., twice", ",
slowly"); a piece that is only a direction after "then" repeats the verb before it ("turn
right, then left"); a piece after a comma that starts with "while", "as", "with" or an -ing
word ("walk forward, waving") belongs to the clause before it.

Conventions: one step is 0.3 m; "a little"/"a bit"/"slightly" is flagged `vague` (the
resolver reads it as 0.5 m or 30 degrees); "a quarter turn" 90 degrees; "a half turn",
"turn around", "about face", "u-turn" 180; "a full circle", "a full turn", "all the way
around" 360; "N turns"/"N rotations" N x 360; "a few" 3, "a couple" 2.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, fields

from controller.text.numbers import words_to_digits


def _words(text: str) -> frozenset[str]:
    """The whitespace-separated words of `text`."""
    return frozenset(text.split())


STEP_M = 0.3  # one step, the stated convention
MAX_PROMPT_CHARS = 400

_NUM = r"(\d+(?:\.\d+)?)"

# Politeness and filler, removed wherever they stand (longest first).
_FILLER = [
    r"would you be so kind as to", r"would you mind", r"do you mind", r"i'd like you to", r"i would like you to",
    r"i'd love for you to", r"i'd love you to", r"i want you to", r"i need you to", r"i'd like it if you",
    r"could you", r"can you", r"would you", r"will you", r"you should", r"go ahead and", r"do me a favou?r and",
    r"if you can", r"if you could", r"if possible", r"if you don't mind", r"please", r"pls", r"kindly",
    r"thank you(?: very much)?", r"thanks", r"for me", r"right now", r"right away", r"now", r"just",
    r"let's", r"let us", r"try to", r"try and", r"make sure (?:to|you)", r"be sure to", r"how about you",
    r"hey robot", r"hey", r"hi robot", r"hello robot",
]  # fmt: skip
# The robot addressed by name: at the start, or set off by commas ("robot, walk", "walk, robot, then").
_ADDRESS_RE = re.compile(r"^\s*(?:ok |okay |hey |hi |hello )?(?:robot|buddy|g1)\b\s*,?|,\s*(?:robot|buddy|g1)\s*(?=,|[.!?]|$)")
_FILLER_RE = re.compile(r"\b(?:" + "|".join(_FILLER) + r")\b")
# Words that open a clause without meaning anything there.
_LEADING_RE = re.compile(
    r"^(?:(?:(?:and|then|also|so|ok|okay|alright|all right|well|um|uh|oh|first(?: of all)?|to (?:start|begin)(?: with)?|"
    r"at first|second(?:ly)?|third(?:ly)?|last(?:ly)?|finally|next|after (?:that|this)|afterwards?|after|you)\b|,)\s*)+"
)
_SPLIT_RE = re.compile(
    r"(\s*[.!?;]+(?:\s+|$)|\s*,\s*|\s+and then\s+|\s+and after that\s+|\s+then\s+|\s+after that\s+|\s+after this\s+|"
    r"\s+afterwards?\s+|\s+and finally\s+|\s+finally\s+|\s+lastly\s+|\s+and lastly\s+|\s+next\s+|\s+followed by\s+|"
    r"\s+once (?:that's|that is|you're|you are) done\s+|\s+when (?:you're|you are) done\s+|\s+and\s+)"
)
_SIMULTANEOUS_RE = re.compile(
    r"\s+(?:while|whilst|as you|as|at the same time as|and at the same time|at the same time|simultaneously|meanwhile)\s+"
)
_SAME_TIME_RE = re.compile(r"\s*\b(?:at the same time|simultaneously|meanwhile)\b\s*")

FORWARD_WORDS = _words("forward forwards ahead straight onward onwards front")
BACKWARD_WORDS = _words("back backward backwards reverse behind")
LEFT_WORDS = _words("left leftward leftwards counterclockwise anticlockwise")
RIGHT_WORDS = _words("right rightward rightwards clockwise")
SIDEWAYS_WORDS = _words("sideways sidewards sideward")
DIRECTION_WORDS = FORWARD_WORDS | BACKWARD_WORDS | LEFT_WORDS | RIGHT_WORDS | SIDEWAYS_WORDS | {"side", "around", "round"}
SLOW_WORDS = _words("slow slowly carefully gently cautiously leisurely gradually steadily")
FAST_WORDS = _words("fast quickly quick briskly brisk rapidly swiftly speedily hurry hurriedly")
_UNIT_WORDS = _words(
    "m meter meters metre metres cm centimeter centimeters centimetre centimetres ft foot feet yard yards step steps "
    "pace paces stride strides s sec secs second seconds min mins minute minutes degree degrees deg degs times time"
)
# Words that say nothing about which action: a piece made only of these (and numbers) modifies its neighbour.
_MODIFIER_WORDS = (
    _UNIT_WORDS
    | SLOW_WORDS
    | FAST_WORDS
    | _words(
        "a an the to your my of for by in on at about around roughly approximately exactly more again each way "
        "total altogether all over bit little tad touch slightly pace speed another same distance per"
    )
)
_GERUND_EXCEPTIONS = _words(
    "nothing something anything everything thing string ceiling morning evening during king ring starting beginning building"
)
_GERUND_BLOCKERS = _words("hand hands arm arms keep keeping start starting stop stopping the a an your my this that")
_BODY_STATE_RE = re.compile(
    r"\b(?:arms?|hands?)\b.*\b(?:raised|up|lifted|high|air|out|outstretched|extended|crossed|folded|hips?|waving|above)\b"
)
_GESTURE_VERB_RE = re.compile(r"\b(?:wave|waving|raise|raising|lift|lifting|point|pointing|reach|reaching|cross|crossing|put|hold)\b")


_TRANSLATE = str.maketrans({"’": "'", "‘": "'", "“": '"', "”": '"', "—": ",", "–": ",", "\n": " "})


def normalize(prompt: str) -> str:
    """Lower case, plain quotes, numbers as digits, politeness and filler removed, one space between words."""
    text = prompt.lower()
    text = text.translate(_TRANSLATE)
    text = text.replace("°", " degrees ")
    text = re.sub(r"[\"()\[\]{}*_~`]", " ", text)
    text = re.sub(r"\bright after\b", "after", text)
    text = re.sub(r"\ball right\b", " ", text)
    text = re.sub(r"\bas (?:fast|quickly|quick) as (?:you can|possible)\b", "fast", text)
    text = re.sub(r"\bas (?:slow|slowly) as (?:you can|possible)\b", "slowly", text)
    text = re.sub(r"\btake your time\b", "slowly", text)
    text = re.sub(r"(\d)\s*-\s*(?=[a-z])", r"\1 ", text)  # 90-degree
    text = re.sub(r"(\d)([a-z°]+)\b", r"\1 \2", text)  # 2m, 90deg, 3x
    text = re.sub(r"([,;!?]|\.(?!\d))", r" \1 ", text)  # punctuation apart from words, so numbers read across it
    text = words_to_digits(text)
    text = re.sub(r"\b(?:do|make|spin|turn|pull off) an? (90|180|270|360|540|720)\b(?! degrees)", r"turn \1 degrees", text)  # "do a 360"
    text = re.sub(r"\bx (\d+)\b", r"\1 times", text)
    text = re.sub(r"\b(\d+) x\b", r"\1 times", text)
    text = _ADDRESS_RE.sub(" ", text)
    text = _FILLER_RE.sub(" ", text)
    text = re.sub(r"\s+([,.!?;])", r"\1", text)
    text = re.sub(r"([,;])\1+", r"\1", text)
    return re.sub(r"\s+", " ", text).strip(" ,")


def _tokens(text: str) -> list[str]:
    return re.findall(r"[a-z']+|\d+(?:\.\d+)?|-", text)


def _is_number(token: str) -> bool:
    return bool(re.fullmatch(r"\d+(?:\.\d+)?", token))


def _kind(piece: str) -> str:
    """ "empty", "modifier" (no action, no direction), "direction" (directions and modifiers only) or "action"."""
    tokens = [t for t in _tokens(piece) if t != "-"]
    if not tokens:
        return "empty"
    if tokens[0] == "step":  # "then step back": the verb (a unit only after a number: "back two steps")
        return "action"
    if all(t in _MODIFIER_WORDS or _is_number(t) for t in tokens):
        return "modifier"
    if all(t in _MODIFIER_WORDS or t in DIRECTION_WORDS or _is_number(t) for t in tokens):
        return "direction"
    return "action"


def _strip_leading(piece: str) -> str:
    return _LEADING_RE.sub("", piece.strip()).strip(" ,")


def _starts_simultaneous(piece: str) -> bool:
    words = piece.split()
    if not words:
        return False
    first = words[0]
    if first in ("while", "whilst", "with", "as", "meanwhile", "simultaneously"):
        return True
    return first.endswith("ing") and len(first) > 4 and first not in _GERUND_EXCEPTIONS


def split_clauses(prompt: str) -> list[str]:
    """The prompt's clauses in order, normalized (see the module docstring for the rules)."""
    text = normalize(prompt)
    pieces = _SPLIT_RE.split(text)
    clauses: list[str] = []
    pending = ""  # modifiers before any clause ("slowly, walk forward")
    delimiter = ""
    for i, raw in enumerate(pieces):
        if i % 2 == 1:
            delimiter = raw.strip()
            continue
        piece = raw.strip()
        if delimiter != "and":
            piece = _strip_leading(piece)
        kind = _kind(piece)
        if kind == "empty":
            continue
        joined_by_and = delimiter == "and"
        if clauses and joined_by_and and _SAME_TIME_RE.search(piece):
            # "walk forward and wave at the same time": one clause
            clauses[-1] = f"{clauses[-1]} while {_SAME_TIME_RE.sub(' ', piece).strip()}"
        elif clauses and kind == "modifier":
            clauses[-1] = f"{clauses[-1]}{',' if delimiter == ',' else ''} {piece}"
        elif clauses and kind == "direction" and joined_by_and:
            clauses[-1] = f"{clauses[-1]} and {piece}"
        elif clauses and kind == "direction":
            verb = clauses[-1].split()[0]
            clauses.append(f"{verb} {piece}")
        elif clauses and delimiter in (",", "") and _starts_simultaneous(piece):
            clauses[-1] = f"{clauses[-1]} {piece}"
        elif kind == "modifier":
            pending = f"{pending} {piece}".strip()
        else:
            if joined_by_and:
                piece = _strip_leading(piece)
            clauses.append(f"{piece} {pending}".strip() if pending else piece)
            pending = ""
    if pending and clauses:
        clauses[-1] = f"{clauses[-1]} {pending}"
    elif pending:
        clauses.append(pending)
    return [c.strip(" ,") for c in clauses if c.strip(" ,")]


def split_parts(clause: str) -> list[str]:
    """The simultaneous parts of one clause, the base action first where the text puts it first."""
    parts: list[str] = []
    for piece in _SIMULTANEOUS_RE.split(f" {clause} "):
        piece = piece.strip(" ,")
        # "turn left with both arms raised" -> "turn left" + "both arms raised" (not "wave with your right hand")
        m = re.search(r"\bwith\b", piece)
        if m and _BODY_STATE_RE.search(piece[m.end() :]) and not _GESTURE_VERB_RE.search(piece[: m.start()]):
            parts += [piece[: m.start()].strip(" ,"), piece[m.end() :].strip(" ,")]
        else:
            parts.append(piece)
    out: list[str] = []
    for piece in parts:
        words = piece.split()
        start = 0
        for j in range(1, len(words)):
            w = words[j]
            if (
                w.endswith("ing")
                and len(w) > 4
                and w not in _GERUND_EXCEPTIONS
                and words[j - 1] not in _GERUND_BLOCKERS
                and not _is_number(words[j - 1])
            ):
                out.append(" ".join(words[start:j]))
                start = j
        out.append(" ".join(words[start:]))
    cleaned = [re.sub(r"^(?:you're|you are|you|keep|keeping)\s+", "", p.strip(" ,")).strip() for p in out]
    return [p for p in cleaned if p]


@dataclass(frozen=True)
class Quantities:
    """What one piece of text states; None where it says nothing.

    `distances`: (direction, metres) pairs when each direction has its own distance ("1 m
    forward and 2 m left"); `distance_m` the one distance otherwise. `direction`: travel
    direction words found, in order (forward, backward, left, right, sideways). `side`:
    left/right for a turn; `hand`: left/right/both for a gesture. `turn_deg`: a stated turn
    (magnitude). `bare_number`: a number with no unit (a turn reads it as degrees).
    """

    distance_m: float | None = None
    distances: tuple[tuple[str, float], ...] = ()
    directions: tuple[str, ...] = ()
    duration_s: float | None = None
    turn_deg: float | None = None
    side: str | None = None
    hand: str | None = None
    speed: str | None = None
    repetitions: float | None = None
    vague: bool = False
    negative: bool = False
    bare_number: float | None = None
    shape: str | None = None
    speed_mps: float | None = None

    def as_dict(self) -> dict[str, float | str]:
        """The stated values, for a clause's `quantities` (empty fields left out)."""
        out: dict[str, float | str] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None or value == () or value is False:
                continue
            if f.name == "distances":
                for direction, metres in value:
                    out[f"{direction}_m"] = metres
            elif f.name == "directions":
                out["direction"] = " ".join(value)
            elif isinstance(value, bool):
                out[f.name] = "yes"
            else:
                out[f.name] = value
        return out


_DISTANCE_RE = re.compile(
    _NUM + r"\s*(m|meters?|metres?|cm|centimet(?:er|re)s?|ft|feet|foot|yards?|yd|steps?|paces?|strides?)\b(?!\s*(?:per|/))"
)
_SPEED_RE = re.compile(_NUM + r"\s*(?:m|meters?|metres?)\s*(?:per second|per sec|/\s*s|a second)\b")
_DURATION_RE = re.compile(_NUM + r"\s*(seconds?|secs?|s|minutes?|mins?)\b")
_DEGREES_RE = re.compile(_NUM + r"\s*(degrees?|degs?)\b")
_TURNS_RE = re.compile(_NUM + r"\s*(?:full\s+|complete\s+|whole\s+)?(?:turns?|rotations?|revolutions?|spins?|circles?)\b")
_REPS_RE = re.compile(_NUM + r"\s*times?\b")
_UNIT_M = {"m": 1.0, "cm": 0.01, "ft": 0.3048, "feet": 0.3048, "foot": 0.3048, "yard": 0.9144, "yd": 0.9144, "step": STEP_M}
_HALF_TURN_RE = re.compile(
    r"\b(?:half (?:a )?(?:turn|rotation|circle|spin)|turn (?:a)?round|about face|u turn|"
    r"face (?:the )?(?:other|opposite) (?:way|direction)|the (?:other|opposite) (?:way|direction)|face back(?:wards?)?|turn back)\b"
)
_QUARTER_TURN_RE = re.compile(r"\bquarter (?:of a )?(?:turn|rotation|circle|spin)\b|\ba quarter\b")
_FULL_TURN_RE = re.compile(
    r"\b(?:full|complete|whole) (?:circle|turn|rotation|revolution|spin|360)\b|\ball the way (?:a)?round\b|\b360\b(?! degrees)"
)
_VAGUE_RE = re.compile(r"\b(?:a little(?: bit)?|a bit|a tad|a touch|slightly|a smidge|a little way|a short way|a few inches)\b")


def _unit_metres(unit: str) -> float:
    for key, metres in _UNIT_M.items():
        if unit == key or (unit.startswith(key) and key not in ("m", "ft", "yd")):
            return metres
    if unit.startswith(("met", "m")):
        return 1.0
    if unit.startswith("centi"):
        return 0.01
    if unit.startswith(("pace", "stride")):
        return STEP_M
    return 1.0


def _direction_of(word: str) -> str | None:
    if word in FORWARD_WORDS:
        return "forward"
    if word in BACKWARD_WORDS:
        return "backward"
    if word in LEFT_WORDS:
        return "left"
    if word in RIGHT_WORDS:
        return "right"
    if word in SIDEWAYS_WORDS:
        return "sideways"
    return None


def read_quantities(text: str) -> Quantities:
    """The quantities `text` (normalized) states."""
    values: dict[str, object] = {}
    used: list[tuple[int, int]] = []

    def take(m: re.Match[str]) -> None:
        used.append(m.span())

    speed = _SPEED_RE.search(text)
    if speed:
        values["speed_mps"] = float(speed[1])
        take(speed)
        text = text[: speed.start()] + " " * (speed.end() - speed.start()) + text[speed.end() :]  # not also a distance or a time
    reps = list(_REPS_RE.finditer(text))
    if reps:
        values["repetitions"] = float(reps[0][1])
        take(reps[0])
    durations = list(_DURATION_RE.finditer(text))
    if durations:
        m = durations[0]
        values["duration_s"] = float(m[1]) * (60.0 if m[2].startswith("min") else 1.0)
        take(m)
    elif re.search(r"\b(?:a moment|a sec)\b", text):
        values["duration_s"] = 2.0
    elif re.search(r"\ba while\b", text):
        values["duration_s"] = 5.0
    degrees = list(_DEGREES_RE.finditer(text))
    turns = list(_TURNS_RE.finditer(text))
    if degrees:
        values["turn_deg"] = float(degrees[0][1])
        take(degrees[0])
    elif turns:
        values["turn_deg"] = 360.0 * float(turns[0][1])
        take(turns[0])
    elif _QUARTER_TURN_RE.search(text):
        values["turn_deg"] = 90.0
    elif _HALF_TURN_RE.search(text):
        values["turn_deg"] = 180.0
    elif _FULL_TURN_RE.search(text):
        values["turn_deg"] = 360.0
    if re.search(r"\b360\b", text) and "turn_deg" in values:
        used.extend(m.span() for m in re.finditer(r"\b360\b", text))
    distance_matches = list(_DISTANCE_RE.finditer(text))
    for m in distance_matches:
        take(m)
    words = _tokens(text)
    directions = [d for d in (_direction_of(w) for w in words) if d is not None]
    # "a few steps back": "back" is a direction; "turn back" etc. are read by the turn patterns
    if directions:
        values["directions"] = tuple(dict.fromkeys(directions))
    if distance_matches:
        metres = [float(m[1]) * _unit_metres(m[2]) for m in distance_matches]
        if len(metres) >= 2 and len(metres) == len(directions) and len(set(directions)) == len(directions):
            values["distances"] = tuple(zip(directions, (round(x, 4) for x in metres), strict=True))
            values["distance_m"] = round(sum(metres), 4)
        else:
            values["distance_m"] = round(sum(metres), 4)
    if "left" in directions and "right" not in directions:
        values["side"] = "left"
    elif "right" in directions and "left" not in directions:
        values["side"] = "right"
    elif "left" in directions and "right" in directions:
        values["side"] = directions[[d in ("left", "right") for d in directions].index(True)]
    if re.search(r"\bboth\b|\btwo (?:hands|arms)\b|\b2 (?:hands|arms)\b", text) or (
        re.search(r"\b(?:hands|arms)\b", text) and not re.search(r"\b(?:left|right)\b", text)
    ):
        values["hand"] = "both"
    elif re.search(r"\bleft\b", text):
        values["hand"] = "left"
    elif re.search(r"\bright\b", text):
        values["hand"] = "right"
    if any(w in SLOW_WORDS for w in words):
        values["speed"] = "slow"
    elif any(w in FAST_WORDS for w in words):
        values["speed"] = "fast"
    if _VAGUE_RE.search(text):
        values["vague"] = True
    if re.search(r"(?:^|\s)-\s*\d|\bminus\b|\bnegative\b", text):
        values["negative"] = True
    if re.search(r"\bcircles?\b", text) and not turns and "turn_deg" not in values:
        values["shape"] = "circle"
    elif re.search(r"\bsquares?\b", text):
        values["shape"] = "square"
    # A number no unit claimed (and not part of a claimed span): "turn left 90".
    for m in re.finditer(_NUM, text):
        if not any(a <= m.start() < b for a, b in used):
            values["bare_number"] = float(m[1])
            break
    return Quantities(**values)  # type: ignore[arg-type]


def action_phrase(text: str) -> str:
    """The words of `text` that name the action (numbers, units, times and fillers removed): what the encoder reads."""
    phrase = _SPEED_RE.sub(" ", text)
    phrase = _REPS_RE.sub(" ", phrase)
    phrase = _DURATION_RE.sub(" ", phrase)
    phrase = _DEGREES_RE.sub(" ", phrase)
    phrase = _DISTANCE_RE.sub(" ", phrase)
    phrase = re.sub(r"\bfor\s+(?=$|,)", " ", phrase)
    phrase = re.sub(r"\d+(?:\.\d+)?", " ", phrase)
    phrase = re.sub(r"[,.!?;]", " ", phrase)
    phrase = re.sub(r"\s+", " ", phrase).strip()
    return re.sub(r"\s+(?:for|by|of)$", "", phrase)
