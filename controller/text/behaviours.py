"""One handler per behaviour: a phrase's words become a typed step of the program.

`phrase_step(part)` finds the part's head (`grammar.py`) and hands the rest of its lexemes
to the behaviour's handler. A handler takes what it understands from `Args` (a direction,
a distance, a count, a hand) and the words it leaves are refused by name: "turn left
3 m" is refused for "3 m", not run as a turn. The result is a typed step (`Walk`, `Turn`,
`Path`, `Stand`, `Return`, `Gesture`, `Lower`, `Hold`, `Repeat`); `resolve.py` puts the
steps of a clause together and makes them executable.

Conventions (stated, not guessed per prompt): speed 0.5 m/s, slow 0.3, fast 0.8, or a stated
speed from 0.1 to 0.8 m/s; turning rate 0.8 rad/s, slow 0.5, fast 1.2; a walk with no
distance 1 m ("a step" 0.3 m), "a little" 0.5 m or 30 degrees; a walk with no direction goes
forward, "sideways" with no side left; "turn" with no angle 90 degrees, with no side left;
"turn around" 180, "spin" 360; a number with no unit is degrees in a turn, and in a walk
takes the distance unit said before it in the prompt ("4 steps back, then 2 to the right"),
else it is refused. Paths: radius 1 m (at least 0.3 m, at most 5 m), an arc 90 degrees,
a semicircle 180, a circle 360, a figure eight a circle to the left and one to the right
(the side said first goes first); a distance in an arc with no radius is its length.
Walking while turning is one arc: its length (the walk's) over its angle (the turn's), or
a radius of 1 m. A gesture alone lasts 3 s; "wave N times" is N waves at 1.5 Hz; "wait"
with no time 2 s; "lower your arms" 1 s. Point and reach are the right arm's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from controller.text.grammar import TURN_NUMBERS, Lexeme, Part, refuse
from controller.text.lexicon import REASONS, STEP_M, Cat

SPEEDS = {"slow": 0.3, "normal": 0.5, "fast": 0.8}  # m/s
YAW_RATES = {"slow": 0.5, "normal": 0.8, "fast": 1.2}  # rad/s
MIN_SPEED, MAX_SPEED = 0.1, SPEEDS["fast"]
DEFAULT_WALK_M = 1.0
VAGUE_WALK_M = 0.5
VAGUE_TURN_DEG = 30.0
DEFAULT_TURN_DEG = 90.0
DEFAULT_RADIUS_M = 1.0
MIN_RADIUS_M, MAX_RADIUS_M = 0.3, 5.0
DEFAULT_ARC_DEG = 90.0
SQUARE_SIDE_M = 1.0
GESTURE_S = 3.0
WAVE_HZ = 1.5
WAVE_BLEND_S = 0.5
DEFAULT_WAIT_S = 2.0
LOWER_ARMS_S = 1.0
MAX_REPETITIONS = 10


# --- the typed steps -----------------------------------------------------------------------


@dataclass(frozen=True)
class Walk:
    """Straight legs one after the other, each (forward, left) in m in the clause's start frame, relative to the leg before."""

    legs: tuple[tuple[float, float], ...]
    speed_mps: float
    speed: str = "normal"
    distance_stated: bool = False  # False: the length is a default ("walk forward": 1 m)


@dataclass(frozen=True)
class Turn:
    degrees: float  # + left
    speed: str = "normal"


@dataclass(frozen=True)
class Path:
    """A curved path: arcs (radius m, angle deg + left), followed without stopping; or a square's corners (stop-and-go)."""

    shape: str
    arcs: tuple[tuple[float, float], ...] = ()
    corners: tuple[tuple[float, float, float], ...] = ()  # a square: (forward, left, heading deg) of each corner
    speed_mps: float = SPEEDS["normal"]
    speed: str = "normal"


@dataclass(frozen=True)
class Stand:
    seconds: float


@dataclass(frozen=True)
class Return:
    speed: str = "normal"


@dataclass(frozen=True)
class Gesture:
    """Gestures on named arms (a report name each), for `seconds` (None: as long as the clause's motion, or 3 s alone)."""

    names: tuple[str, ...]
    seconds: float | None = None
    waves: int | None = None


@dataclass(frozen=True)
class Lower:
    """Arms back to rest: a short stand with no gesture."""


@dataclass(frozen=True)
class Hold:
    """The gestures of the clause before go on ("keep it up"), for `seconds` (None: the clause's own length or 3 s)."""

    seconds: float | None = None


@dataclass(frozen=True)
class Repeat:
    """The clause before, again."""

    times: int = 1


Step = Walk | Turn | Path | Stand | Return | Gesture | Lower | Hold | Repeat


@dataclass(frozen=True)
class PhraseStep:
    """What one part of a clause asks for: its step, how many times, and the quantities read (for the printout)."""

    step: Step
    text: str
    repetitions: int = 1
    quantities: dict[str, float | str] = field(default_factory=dict)
    open_ended: bool = False  # "keep waving" with no time: bounded only by a motion in the same clause


@dataclass
class Context:
    """What a handler needs beyond its words: the distance unit said last in the prompt (for a bare number in a walk)."""

    distance_unit: float | None = None  # metres per unit of the distance said last


# --- arguments ------------------------------------------------------------------------------

_NEUTRAL = frozenset({Cat.FILLER, Cat.GRAMMAR, Cat.ORDINAL, Cat.PUNCT, Cat.AGAIN})


class Args:
    """A part's lexemes other than its head; a handler takes what it uses, `finish` refuses the rest by name."""

    def __init__(self, part: Part, head: Sequence[Lexeme]) -> None:
        self.part = part
        self.items = [x for x in part.lexemes if not any(x is h for h in head)]
        self.used: set[int] = {i for i, x in enumerate(self.items) if x.cat in _NEUTRAL}

    def take(self, predicate: Callable[[Lexeme], bool]) -> list[Lexeme]:
        out = []
        for i, x in enumerate(self.items):
            if i not in self.used and predicate(x):
                self.used.add(i)
                out.append(x)
        return out

    def peek(self, predicate: Callable[[Lexeme], bool]) -> list[Lexeme]:
        return [x for i, x in enumerate(self.items) if i not in self.used and predicate(x)]

    def cat(self, *cats: Cat) -> list[Lexeme]:
        return self.take(lambda x: x.cat in cats)

    def quantity(self, kind: str) -> list[Lexeme]:
        return self.take(lambda x: x.cat is Cat.QUANTITY and x.kind == kind)

    def remaining(self) -> list[Lexeme]:
        return [x for i, x in enumerate(self.items) if i not in self.used]

    def finish(self, what: str) -> None:
        """Refuse the words no one used: they would otherwise be silently dropped."""
        left = [x for x in self.remaining() if x.cat is not Cat.AND]
        if left:
            words = ", ".join(f'"{x.text}"' for x in left)
            raise refuse(self.part.text, f"{words} {'does' if len(left) == 1 else 'do'} not go with {what}")


def _count(args: Args) -> int:
    counts = args.quantity("count")
    if not counts:
        return 1
    total = math.prod(x.number or 0.0 for x in counts)
    if total != int(total) or not 1 <= total <= MAX_REPETITIONS:
        raise refuse(args.part.text, f"{total:g} times: a whole number from 1 to {MAX_REPETITIONS} is needed")
    return int(total)


def _seconds(args: Args) -> float | None:
    times = args.quantity("time")
    if not times:
        return None
    seconds = sum(x.number or 0.0 for x in times)
    if seconds <= 0:
        raise refuse(args.part.text, "distances, angles and times must be positive")
    return seconds


def _speed(args: Args) -> str:
    speeds = {x.value for x in args.cat(Cat.SPEED)}
    if len(speeds) > 1:
        raise refuse(args.part.text, "it cannot go slowly and fast at once")
    return speeds.pop() if speeds else "normal"


def _stated_speed(args: Args) -> float | None:
    stated = args.quantity("speed")
    if not stated:
        return None
    value = stated[0].number or 0.0
    if not MIN_SPEED <= value <= MAX_SPEED:
        raise refuse(args.part.text, f"{value:g} m/s is outside the walking speeds it plans ({MIN_SPEED:g} to {MAX_SPEED:g} m/s)")
    return value


def _side(args: Args, default: str = "left") -> str:
    sides = [x.value for x in args.take(lambda x: x.cat is Cat.DIR and x.value in ("left", "right"))]
    if len(set(sides)) > 1:
        raise refuse(args.part.text, "it names both sides")
    return sides[0] if sides else default


# --- handlers ---------------------------------------------------------------------------------

_VECTOR = {"forward": (1.0, 0.0), "backward": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}


def walk(args: Args, ctx: Context, head: Lexeme) -> PhraseStep:
    """Straight walks: one leg, a diagonal, legs with their own distances, there and back."""
    speed = _speed(args)
    stated = _stated_speed(args)
    seconds = _seconds(args)
    vague = bool(args.cat(Cat.VAGUE))
    count = _count(args)
    if args.peek(lambda x: x.cat is Cat.UNSUPPORTED and x.value == "in_place"):
        raise refuse(args.part.text, REASONS["in_place"])
    groups: list[list[Lexeme]] = [[]]
    for x in args.remaining():
        if x.cat is Cat.AND:
            groups.append([])
        elif x.cat is Cat.DIR or (x.cat is Cat.QUANTITY and x.kind == "distance") or x.cat is Cat.NUMBER:
            groups[-1].append(x)
    args.take(lambda x: x.cat in (Cat.DIR, Cat.AND) or (x.cat is Cat.QUANTITY and x.kind == "distance"))
    bare = args.cat(Cat.NUMBER)
    groups = [g for g in groups if g]
    legs = _legs(args, groups, bare, ctx, "backward" if head.text.startswith("back") else "forward")  # "back up": backward
    args.finish("walking")
    distance_given = any(metres is not None for _, metres in legs)
    if stated is not None:
        speed_mps = stated
    elif seconds is not None and distance_given:
        total = sum(m or 0.0 for _, m in legs)
        speed_mps = total / seconds  # "1 m in 5 s"
        if not MIN_SPEED <= speed_mps <= MAX_SPEED:
            raise refuse(args.part.text, f"{total:g} m in {seconds:g} s is {speed_mps:.2g} m/s, outside {MIN_SPEED:g} to {MAX_SPEED:g} m/s")
    else:
        speed_mps = SPEEDS[speed]
    out: list[tuple[float, float]] = []
    for (ux, uy), metres in legs:
        if metres is None:
            if seconds is not None:
                metres = speed_mps * seconds
            elif vague:
                metres = VAGUE_WALK_M
            elif head.text in ("step", "stepping", "sidestep"):
                metres = STEP_M
            else:
                metres = DEFAULT_WALK_M
        out.append((ux * metres, uy * metres))
    quantities: dict[str, float | str] = {"distance_m": round(sum(math.hypot(*leg) for leg in out), 3), "speed_mps": speed_mps}
    stated_length = distance_given or seconds is not None
    return PhraseStep(Walk(tuple(out), speed_mps, speed, stated_length), args.part.text, count, quantities)


def _unit(directions: Sequence[str]) -> tuple[float, float]:
    ux = uy = 0.0
    for d in directions:
        vx, vy = _VECTOR[d]
        ux, uy = ux + vx, uy + vy
    norm = math.hypot(ux, uy)
    return (ux / norm, uy / norm) if norm > 1e-9 else (0.0, 0.0)


def _directions(args: Args, group: Sequence[Lexeme]) -> list[str]:
    names = [x.value for x in group if x.cat is Cat.DIR]
    if "diagonal" in names:
        names = [n for n in names if n != "diagonal"]
        if len({n for n in names if n in ("forward", "backward")}) != 1 or len({n for n in names if n in ("left", "right")}) != 1:
            raise refuse(args.part.text, 'a diagonal needs a way and a side ("diagonally forward and to the left")')
    if "sideways" in names:
        names = [n for n in names if n != "sideways"]
        if not any(n in ("left", "right") for n in names):
            names.append("left")
    return list(dict.fromkeys(names))


def _legs(
    args: Args, groups: list[list[Lexeme]], bare: Sequence[Lexeme], ctx: Context, default: str
) -> list[tuple[tuple[float, float], float | None]]:
    """(unit direction, metres or None) per leg; `default` where no direction is said."""
    text = args.part.text
    if bare and ctx.distance_unit is None:
        raise refuse(text, f"the number {bare[0].text} has no unit (meters, steps, seconds)")
    distances: list[float | None] = []
    for g in groups:
        found = [x.number or 0.0 for x in g if x.cat is Cat.QUANTITY]
        found += [(x.number or 0.0) * (ctx.distance_unit or 1.0) for x in g if x.cat is Cat.NUMBER]
        if any(m <= 0 for m in found):
            raise refuse(text, "distances, angles and times must be positive")
        distances.append(sum(found) if found else None)
    for g in groups:
        for x in g:
            if x.cat is Cat.QUANTITY and x.unit is not None:
                ctx.distance_unit = x.unit.factor
    if any(x.cat is Cat.DIR and x.value == "diagonal" for g in groups for x in g):
        groups = [[x for g in groups for x in g]]  # "diagonally forward and to the left": one leg
        distances = [sum(d or 0.0 for d in distances) or None]
    directions = [_directions(args, g) for g in groups] or [[]]
    if len(groups) >= 2 and all(d is not None for d in distances):  # "2 m forward and 1 m to the left": one leg after the other
        legs: list[tuple[tuple[float, float], float | None]] = []
        previous = [default]
        for dirs, metres in zip(directions, distances, strict=True):
            dirs = dirs or previous
            legs.append((_unit(dirs), metres))
            previous = dirs
        return _checked(text, legs)
    flat = [d for dirs in directions for d in dirs]
    metres = next((d for d in distances if d is not None), None)
    if len(directions) == 2 and directions[0] and directions[1] and _opposite(directions[0], directions[1]):
        first = _unit(directions[0])
        return _checked(text, [(first, metres), ((-first[0], -first[1]), metres)])  # there and back
    return _checked(text, [(_unit(flat or [default]), metres)])


def _opposite(a: Sequence[str], b: Sequence[str]) -> bool:
    ua, ub = _unit(a), _unit(b)
    return ua[0] * ub[0] + ua[1] * ub[1] < -0.99


def _checked(text: str, legs: list[tuple[tuple[float, float], float | None]]) -> list[tuple[tuple[float, float], float | None]]:
    for (ux, uy), _ in legs:
        if ux == 0.0 and uy == 0.0:
            raise refuse(text, "its directions cancel out")
    return legs


def turn(args: Args, ctx: Context, head: Lexeme) -> PhraseStep:
    """Turning in place: by degrees, by words ("a quarter turn", "around"), or the defaults."""
    speed = _speed(args)
    count = _count(args)
    args.take(lambda x: x.cat is Cat.UNSUPPORTED and x.value == "in_place")
    spin = head.text.startswith(("spin", "twirl")) or head.value == "spin"
    angles = args.quantity("angle")
    words = args.cat(Cat.ANGLE)
    shapes = args.take(lambda x: x.cat is Cat.SHAPE and x.value in ("circle", "full_circle"))  # "turn a full circle": in place
    vague = bool(args.cat(Cat.VAGUE))
    bare = args.cat(Cat.NUMBER)
    back = args.take(lambda x: x.cat is Cat.DIR and x.value == "backward")  # "turn back": around
    side = _side(args)
    args.finish("turning")
    stated = [x.number or 0.0 for x in angles] + [(x.number or 0.0) for x in bare]
    if len(stated) + len(words) + len(shapes) > 1:
        raise refuse(args.part.text, "it names more than one angle")
    if stated:
        degrees = stated[0]
    elif words:
        degrees = (360.0 if spin else 180.0) if words[0].value == "around" else float(words[0].value)
    elif shapes or back:
        degrees = 360.0 if shapes else 180.0
    elif vague:
        degrees = VAGUE_TURN_DEG
    elif spin:
        degrees = 360.0
    else:
        degrees = DEFAULT_TURN_DEG
    if degrees <= 0:
        raise refuse(args.part.text, "distances, angles and times must be positive")
    signed = degrees if side == "left" else -degrees
    return PhraseStep(Turn(signed, speed), args.part.text, count, {"turn_deg": signed})


def path(args: Args, ctx: Context, head: Lexeme) -> PhraseStep:
    """Curved paths: arcs, semicircles, circles, figure eights (continuous); a square (stop at its corners)."""
    text = args.part.text
    speed = _speed(args)
    stated = _stated_speed(args)
    count_shapes = args.quantity("shape_count")
    count = _count(args)
    shapes = args.cat(Cat.SHAPE)
    names = {"circle" if x.value == "full_circle" else x.value for x in shapes} or ({"circle"} if count_shapes else set())
    if len(names) != 1:
        raise refuse(text, "it names more than one shape")
    shape = names.pop()
    radius_words = args.cat(Cat.RADIUS)
    diameter_words = args.cat(Cat.DIAMETER)
    distances = args.quantity("distance")
    angles = args.quantity("angle")
    sides = [x.value for x in args.take(lambda x: x.cat is Cat.DIR and x.value in ("left", "right"))]
    args.take(lambda x: x.cat is Cat.DIR and x.value == "forward")
    args.take(lambda x: x.cat is Cat.ANGLE and x.value == "around")  # "walk around in a circle"
    if len(set(sides)) > 1 and shape != "figure_eight":
        raise refuse(text, "it names both sides")
    args.finish("a path")
    laps = 1
    if count_shapes:
        laps = int(count_shapes[0].number or 0)
        if laps != count_shapes[0].number or not 1 <= laps <= MAX_REPETITIONS:
            raise refuse(text, f"{count_shapes[0].text}: a whole number of laps from 1 to {MAX_REPETITIONS} is needed")
    speed_mps = stated if stated is not None else SPEEDS[speed]
    if shape == "square":
        if angles or radius_words or diameter_words or len(distances) > 1:
            raise refuse(text, "a square takes one side length")
        side_m = (distances[0].number or 0.0) if distances else SQUARE_SIDE_M
        sign = -1.0 if sides[:1] == ["right"] else 1.0
        corners = []
        for lap in range(laps):
            for k, (f, lt) in enumerate(((side_m, 0.0), (side_m, sign * side_m), (0.0, sign * side_m), (0.0, 0.0))):
                corners.append((f, lt, sign * 90.0 * (4 * lap + k + 1)))
        return PhraseStep(Path("square", corners=tuple(corners), speed_mps=speed_mps, speed=speed), text, count, {"side_m": side_m})
    radius = _radius(text, radius_words, diameter_words, distances, shape)
    angle = {"circle": 360.0, "semicircle": 180.0, "quarter_circle": 90.0, "arc": DEFAULT_ARC_DEG, "figure_eight": 360.0}[shape]
    if angles:
        if shape not in ("arc",):
            raise refuse(text, f'"{angles[0].text}" does not go with a {shape.replace("_", " ")}')
        angle = angles[0].number or 0.0
    if shape == "arc" and distances and radius is None:
        radius = (distances[0].number or 0.0) / math.radians(angle)  # "2 m in an arc": its length
    radius = DEFAULT_RADIUS_M if radius is None else radius
    if not MIN_RADIUS_M <= radius <= MAX_RADIUS_M or angle <= 0:
        raise refuse(text, f"a radius of {radius:.2g} m is outside the {MIN_RADIUS_M:g} to {MAX_RADIUS_M:g} m it follows")
    first = 1.0 if (sides[:1] or ["left"])[0] == "left" else -1.0
    loop = [(radius, first * 360.0), (radius, -first * 360.0)] if shape == "figure_eight" else [(radius, first * angle)]
    arcs = loop * laps
    speed_mps = min(speed_mps, radius * YAW_RATES["fast"])  # a tight curve is walked slower, never turned faster than 1.2 rad/s
    quantities: dict[str, float | str] = {"shape": shape, "radius_m": round(radius, 3), "direction": "left" if first > 0 else "right"}
    return PhraseStep(Path(shape, tuple(arcs), speed_mps=speed_mps, speed=speed), text, count, quantities)


def _radius(text: str, radius: Sequence[Lexeme], diameter: Sequence[Lexeme], distances: Sequence[Lexeme], shape: str) -> float | None:
    if radius and diameter:
        raise refuse(text, "it gives both a radius and a diameter")
    if (radius or diameter) and len(distances) != 1:
        raise refuse(text, f"the {'radius' if radius else 'diameter'} needs one distance")
    if radius:
        return distances[0].number
    if diameter:
        return (distances[0].number or 0.0) / 2.0
    if distances and shape != "arc":
        raise refuse(text, f'say whether "{distances[0].text}" is the radius or the diameter')
    return None


def stand(args: Args, ctx: Context, head: Lexeme) -> PhraseStep:
    seconds = _seconds(args)
    count = _count(args)
    args.take(lambda x: x.cat is Cat.UNSUPPORTED and x.value == "in_place")
    args.finish("standing still")
    seconds = (seconds if seconds is not None else DEFAULT_WAIT_S) * count
    return PhraseStep(Stand(seconds), args.part.text, 1, {"duration_s": seconds})


def return_(args: Args, ctx: Context, head: Lexeme) -> PhraseStep:
    speed = _speed(args)
    args.cat(Cat.PLACE)
    args.take(lambda x: x.cat is Cat.DIR and x.value == "backward")
    args.finish("going back to the start")
    return PhraseStep(Return(speed), args.part.text, 1, {"speed_mps": SPEEDS[speed]})


_ONE_ARM = {"point": "right", "reach": "right"}
_BOTH_ONLY = ("arms_crossed", "hands_on_hips")


def gesture(args: Args, ctx: Context, head: Lexeme, behaviour: str) -> PhraseStep:
    """A gesture on the arms the words name: "wave with your left hand", "raise both arms", "hands up"."""
    text = args.part.text
    seconds = _seconds(args)
    counts = args.quantity("count")
    hands = _hands(args, behaviour)
    args.take(lambda x: x.cat is Cat.DIR and x.value == "forward" and behaviour in ("point", "reach"))
    args.take(lambda x: x.cat is Cat.STATE and (x.value == behaviour or (x.value == "reach" and behaviour in ("reach", "point"))))
    args.take(lambda x: x.cat is Cat.UNSUPPORTED and x.value == "in_place")
    args.finish(behaviour.replace("_", " "))
    if behaviour in _ONE_ARM:
        if hands not in (None, _ONE_ARM[behaviour]):
            raise refuse(text, f"it can {behaviour} with its {_ONE_ARM[behaviour]} arm only")
        names: tuple[str, ...] = (behaviour,)
    elif behaviour in _BOTH_ONLY:
        names = (behaviour,)
    else:
        names = (f"{behaviour}_{hands or 'right'}",)
    waves = None
    if counts:
        n = counts[0].number or 0.0
        if n != int(n) or not 1 <= n <= MAX_REPETITIONS:
            raise refuse(text, f"{n:g} times: a whole number from 1 to {MAX_REPETITIONS} is needed")
        if behaviour == "wave":
            waves = int(n)
            seconds = waves / WAVE_HZ + WAVE_BLEND_S if seconds is None else seconds
        else:
            seconds = (seconds or GESTURE_S) * n
    quantities: dict[str, float | str] = {"gestures": " ".join(names)}
    if waves:
        quantities["waves"] = waves
    return PhraseStep(Gesture(names, seconds, waves), text, 1, quantities)


def _hands(args: Args, behaviour: str) -> str | None:
    """left, right, both, "other" (the arm the clause's other gesture leaves), or None (not said)."""
    sides = {x.value for x in args.take(lambda x: x.cat is Cat.DIR and x.value in ("left", "right"))}
    which = {x.value for x in args.cat(Cat.HANDS)}
    bodies = args.cat(Cat.BODY)
    counted = args.quantity("hands")
    plural = any(x.text in ("hands", "arms") for x in bodies) or any((x.number or 0) >= 2 for x in counted)
    if "both" in which or (plural and not sides and "other" not in which):
        return "both"
    if len(sides) > 1:
        return "both"
    if "other" in which:
        return "other"
    if sides:
        return sides.pop()
    return None


def lower(args: Args, ctx: Context, head: Lexeme) -> PhraseStep:
    args.take(lambda x: x.cat in (Cat.BODY, Cat.HANDS, Cat.STATE) or (x.cat is Cat.DIR and x.value in ("left", "right")))
    args.quantity("hands")
    args.finish("lowering the arms")
    return PhraseStep(Lower(), args.part.text, 1, {"duration_s": LOWER_ARMS_S})


def hold(args: Args, ctx: Context, head: Lexeme) -> PhraseStep:
    seconds = _seconds(args)
    args.take(lambda x: x.cat in (Cat.BODY, Cat.HANDS) or (x.cat is Cat.STATE and x.value != "lower"))
    args.finish("holding the pose")
    return PhraseStep(Hold(seconds), args.part.text, 1, {"duration_s": seconds} if seconds else {})


def repeat(args: Args, ctx: Context, head: Lexeme) -> PhraseStep:
    count = _count(args)
    args.finish("repeating")
    return PhraseStep(Repeat(count), args.part.text, 1, {"repetitions": count})


# --- the head of a part ---------------------------------------------------------------------

_GESTURES = ("wave", "raise", "point", "reach", "arms_crossed", "hands_on_hips")


Handler = Callable[[Args, Context, Lexeme], PhraseStep]
# One handler per behaviour; the gestures share `gesture`, which takes the behaviour's name.
HANDLERS: dict[str, Handler] = {
    "walk": walk, "turn": turn, "path": path, "stand": stand, "return": return_, "lower": lower, "hold": hold, "repeat": repeat,
}  # fmt: skip


def phrase_step(part: Part, ctx: Context) -> PhraseStep:
    """The part's step: its head found, its handler run on the other lexemes."""
    lexemes = [x for x in part.lexemes if x.cat is not Cat.PUNCT]
    behaviour, head = _head(part, lexemes)
    head = head + [x for x in lexemes if x.cat is Cat.LIGHT and not any(x is h for h in head)]  # "give a wave": the noun decides
    args = Args(part, head)
    first = head[0] if head else Lexeme(Cat.FILLER, "")
    if first.cat is Cat.VERB and first.value == "hold" and behaviour not in ("hold", *_GESTURES):
        first = head[1] if len(head) > 1 else first  # "keep walking": the walk's own verb
        amounts = (Cat.QUANTITY, Cat.VAGUE, Cat.ANGLE, Cat.SHAPE, Cat.PLACE)
        if not any(x.cat in amounts for x in lexemes):
            raise refuse(part.text, REASONS["unbounded"])  # "keep walking forward": for how long?
    handler = HANDLERS.get(behaviour)
    if handler is not None:
        return handler(args, ctx, first)
    step = gesture(args, ctx, first, behaviour)
    if first.cat is Cat.VERB and first.value == "hold" and not any(x.cat is Cat.QUANTITY for x in lexemes):
        return replace(step, open_ended=True)
    return step


def _head(part: Part, lexemes: Sequence[Lexeme]) -> tuple[str, list[Lexeme]]:
    """(behaviour, the lexemes that named it)."""
    text = part.text
    verbs = [x for x in lexemes if x.cat is Cat.VERB]
    states = [x for x in lexemes if x.cat is Cat.STATE]
    shapes = [x for x in lexemes if x.cat is Cat.SHAPE or (x.cat is Cat.QUANTITY and x.kind == "shape_count")]
    places = [x for x in lexemes if x.cat is Cat.PLACE]
    if verbs and verbs[0].value == "hold" and len(verbs) > 1 and verbs[1].gerund:
        verbs = verbs[1:]  # "keep walking", "keep waving": the -ing verb
        keep = next(x for x in lexemes if x.cat is Cat.VERB)
        behaviour, head = _verb_head(part, verbs, states, shapes, places)
        return behaviour, [keep, *head]
    if verbs:
        return _verb_head(part, verbs, states, shapes, places)
    lights = [x for x in lexemes if x.cat is Cat.LIGHT]
    if lights:
        return _light_head(part, lexemes, lights[0])
    if [x for x in lexemes if x.cat is Cat.REPEAT] or (lexemes and all(x.cat in (Cat.AGAIN, *_NEUTRAL, Cat.QUANTITY) for x in lexemes)):
        return "repeat", [x for x in lexemes if x.cat in (Cat.REPEAT, Cat.AGAIN)][:1]
    holds = [x for x in lexemes if x.cat is Cat.HOLD]
    if holds:
        return "hold", holds[:1]
    if states:
        return _state_behaviour(part, states[0]), states[:1]
    if shapes:
        return "path", []
    if places:
        return "return", []
    if any(x.cat is Cat.ANGLE for x in lexemes):
        return "turn", []
    raise refuse(text, "it names no action")


def _verb_head(
    part: Part, verbs: Sequence[Lexeme], states: Sequence[Lexeme], shapes: Sequence[Lexeme], places: Sequence[Lexeme]
) -> tuple[str, list[Lexeme]]:
    verb = verbs[0]
    others = [v for v in verbs[1:] if v.value != verb.value]
    if others and not (verb.value in ("put", "hold") and all(v.value == "raise" for v in others)):
        raise refuse(part.text, f'"{verb.text}" and "{others[0].text}" in one part: join them with "while" or "then"')
    behaviour = verb.value
    head = [verb, *[v for v in verbs[1:] if v.value == verb.value or v.value == "raise"]]
    named_arm = any(x.cat is Cat.BODY or (x.cat is Cat.QUANTITY and x.kind == "hands") for x in part.lexemes)
    if states and (behaviour == "put" or (behaviour == "hold" and named_arm)):
        return _state_behaviour(part, states[0]), [*head, states[0]]  # "hold your arms up": the pose; "keep it up": hold
    if behaviour == "put":
        raise refuse(part.text, 'say where: "put your hands up", "on your hips" or "down"')
    if behaviour == "hold":
        return "hold", head
    if behaviour == "walk" and shapes:
        return "path", head
    if behaviour == "walk" and places:
        return "return", head
    if behaviour == "turn" and any(s.cat is Cat.SHAPE and s.value not in ("circle", "full_circle") for s in shapes):
        return "path", head  # "turn in an arc"
    if behaviour in ("walk",) and _bare_go_back(part):
        return "return", head
    return behaviour, head


def _bare_go_back(part: Part) -> bool:
    """ "go back" with nothing else: back to the start (a distance makes it a backward walk: "go back 1 m")."""
    content = [x for x in part.lexemes if x.cat not in _NEUTRAL]
    return (
        len(content) == 2
        and content[0].cat is Cat.VERB
        and content[0].text in ("go", "walk", "head", "move", "come", "get")
        and content[1].text == "back"
    )


def _light_head(part: Part, lexemes: Sequence[Lexeme], light: Lexeme) -> tuple[str, list[Lexeme]]:
    """ "do a circle", "take 3 steps", "give a wave", "make a left turn", "do a 360"."""
    after = lexemes[lexemes.index(light) + 1 :]
    for x in after:
        if x.cat is Cat.SHAPE and x.value == "full_circle":
            return "turn", [light]  # "do a full circle": a full turn in place ("walk a full circle" is the path)
        if x.cat is Cat.SHAPE or (x.cat is Cat.QUANTITY and x.kind == "shape_count"):
            return "path", [light]
        if x.cat is Cat.ANGLE or (x.cat is Cat.QUANTITY and x.kind == "angle"):
            return "turn", [light]
        if x.cat is Cat.NUMBER and x.number in TURN_NUMBERS:
            return "turn", [light]
        if x.cat is Cat.QUANTITY and x.kind == "distance" and x.text.split()[-1] in ("step", "steps", "pace", "paces", "stride", "strides"):
            return "walk", [light]
        if x.cat is Cat.VERB and x.value in ("walk", "turn", "wave", "stand"):
            return x.value, [light, x]
        if x.cat is Cat.STATE:
            return _state_behaviour(part, x), [light, x]
        if x.cat is Cat.VERB and x.text in ("step", "steps", "turn", "turns", "wave", "spin", "rest", "pause", "walk"):
            return x.value, [light, x]
    if any(x.cat in (Cat.REPEAT, Cat.AGAIN) for x in after) or any(x.text in ("it", "that", "this", "the same") for x in after):
        return "repeat", [light]
    raise refuse(part.text, f'"{light.text}" names no action it knows')


def _state_behaviour(part: Part, state: Lexeme) -> str:
    if state.value in _GESTURES or state.value == "lower":
        return state.value
    raise refuse(part.text, f'"{state.text}" is not a pose it knows')
