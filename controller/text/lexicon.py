"""The words the text planner knows, each with its part in the grammar (`grammar.py`).

Every word of a prompt must be found here (or be a number) and be used by the parse, or
the prompt is refused naming it: nothing is guessed. An entry is one word or a phrase of
several ("figure 8", "turn around", "could you"); the longest phrase that matches wins.
Extending the planner's vocabulary is adding a line here; a new behaviour is a line here
and a handler in `behaviours.py`.

Categories:
- FILLER: politeness, address, discourse ("please", "could you", "robot", "then" at a
  clause's start is SEQ): consumed, means nothing.
- GRAMMAR: articles, prepositions and pronouns that link the words of a phrase ("to the
  left", "with your hand"): consumed by any phrase that has a head.
- SEQ / SIM / AND: what comes next runs after this clause / at the same time / either.
- VERB: names a behaviour (value); LIGHT: "do", "make", "take": the behaviour is named by
  what follows ("do a circle", "take three steps", "give a wave", "make a left turn").
- DIR: a direction of travel or a side (value: forward, backward, left, right, sideways).
- UNIT: follows a number (value: kind and factor to SI: metres, seconds, degrees, counts).
- SHAPE: a path (circle, arc, semicircle, quarter_circle, figure_eight, square).
- ANGLE: a turn named by words (value: degrees, or "around").
- RADIUS / DIAMETER: the following or preceding distance is the path's size.
- SPEED: slow or fast. VAGUE: "a little" (0.5 m or 30 degrees).
- BODY: hands, arms (value: "hand" or "arm"); HANDS: which (left, right, both, other).
- STATE: a pose word after a body word ("arms up", "hands on your hips", "arms crossed").
- PLACE: the program's start ("to the start", "where you started") for a return.
- HOLD: "keep it up", "hold it": the pose of the clause before goes on.
- REPEAT: "do it again": the clause before once more. AGAIN: "again" beside a verb.
- CONDITION, NEGATION, CORRECTION, UNSUPPORTED (value: reason key): refused.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class Cat(StrEnum):
    FILLER = "filler"
    GRAMMAR = "grammar"
    SEQ = "seq"
    SIM = "sim"
    AND = "and"
    VERB = "verb"
    LIGHT = "light"
    DIR = "dir"
    UNIT = "unit"
    SHAPE = "shape"
    ANGLE = "angle"
    RADIUS = "radius"
    DIAMETER = "diameter"
    SPEED = "speed"
    VAGUE = "vague"
    NUMBER = "number"  # a number no unit follows
    QUANTITY = "quantity"  # a number with its unit
    PUNCT = "punct"
    UNKNOWN = "unknown"
    BODY = "body"
    HANDS = "hands"
    STATE = "state"
    PLACE = "place"
    HOLD = "hold"
    REPEAT = "repeat"
    AGAIN = "again"
    ORDINAL = "ordinal"  # "first", "second": filler at a clause's start only ("second" is also a unit)
    CONDITION = "condition"
    NEGATION = "negation"
    CORRECTION = "correction"
    UNSUPPORTED = "unsupported"


@dataclass(frozen=True)
class Entry:
    """What a word or phrase is: its category and, where it has one, its value (a behaviour, a direction, a reason key)."""

    cat: Cat
    value: str = ""
    gerund: bool = False  # an -ing form of a verb: it can start a simultaneous part ("walk forward waving")


@dataclass(frozen=True)
class Unit:
    """A unit after a number: its kind and the factor to metres, seconds, degrees or a count."""

    kind: str  # distance | time | angle | count | speed | hands | shape_count
    factor: float = 1.0


STEP_M = 0.3  # one step, a stated convention


def _tagged(words: str, value: str) -> dict[str, str]:
    """Each of the space-separated `words` with the same `value`."""
    return dict.fromkeys(words.split(), value)


# Verbs by behaviour (base forms); their -s and -ing forms are added by `_forms`.
VERBS: dict[str, str] = {
    "walk": "walk go move step head stroll advance proceed travel wander shuffle strafe sidestep scoot inch amble saunter",
    "turn": "turn rotate spin pivot twirl swivel face",
    "wave": "wave greet",
    "raise": "raise lift",
    "point": "point",
    "reach": "reach extend",
    "arms_crossed": "cross fold",
    "lower": "lower drop relax",
    "stand": "wait pause stand stay stop halt rest freeze remain idle",
    "return": "return",
    "hold": "keep hold",
    "repeat": "repeat",
    "put": "put place bring throw",  # "put your hands up / on your hips / down": the state decides
}
# Phrases that name a behaviour outright.
PHRASE_VERBS: dict[str, str] = {
    "say hi": "wave", "say hello": "wave", "say hey": "wave", "say goodbye": "wave", "say bye": "wave", "wave hello": "wave",
    "wave goodbye": "wave", "wave bye": "wave", "wave hi": "wave", "stretch out": "reach", "reach out": "reach",
    "back up": "walk", "make your way": "walk", "come forward": "walk", "come closer": "walk", "get moving": "walk",
    "come back": "return", "get back": "return", "head back": "return", "go home": "return",
    "hold still": "stand", "keep still": "stand", "stand still": "stand", "stay still": "stand", "don't move": "stand",
    "do not move": "stand", "hold on": "stand", "stay put": "stand", "stay there": "stand", "stay where you are": "stand",
    "remain still": "stand", "take a break": "stand",
    "follow a": "walk", "follow an": "walk", "follow the": "walk", "do it again": "repeat", "do that again": "repeat",
    "do this again": "repeat", "do the same": "repeat",
    "do the same thing": "repeat", "one more time": "repeat", "repeat that": "repeat", "repeat it": "repeat",
    "reach for the sky": "raise", "stop waving": "lower", "1 more time": "repeat", "once more": "repeat",
}  # fmt: skip
LIGHT_VERBS = "do make take give perform trace draw"

DIRECTIONS: dict[str, str] = {
    "forward": "forward", "forwards": "forward", "ahead": "forward", "straight": "forward", "onward": "forward",
    "onwards": "forward", "front": "forward", "straight ahead": "forward", "in front": "forward",
    "back": "backward", "backward": "backward", "backwards": "backward", "reverse": "backward", "in reverse": "backward",
    "behind": "backward",
    "left": "left", "leftward": "left", "leftwards": "left", "counterclockwise": "left", "anticlockwise": "left",
    "counter clockwise": "left", "anti clockwise": "left",
    "right": "right", "rightward": "right", "rightwards": "right", "clockwise": "right",
    "sideways": "sideways", "sidewards": "sideways", "sideward": "sideways", "to the side": "sideways",
    "diagonally": "diagonal",
}  # fmt: skip
UNITS: dict[str, Unit] = {
    **dict.fromkeys(("m", "meter", "meters", "metre", "metres"), Unit("distance")),
    **dict.fromkeys(("cm", "centimeter", "centimeters", "centimetre", "centimetres"), Unit("distance", 0.01)),
    **dict.fromkeys(("ft", "foot", "feet"), Unit("distance", 0.3048)),
    **dict.fromkeys(("yard", "yards", "yd"), Unit("distance", 0.9144)),
    **dict.fromkeys(("step", "steps", "pace", "paces", "stride", "strides"), Unit("distance", STEP_M)),
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), Unit("time")),
    **dict.fromkeys(("min", "mins", "minute", "minutes"), Unit("time", 60.0)),
    **dict.fromkeys(("degree", "degrees", "deg", "degs"), Unit("angle")),
    **dict.fromkeys(("turn", "turns", "rotation", "rotations", "revolution", "revolutions", "spin", "spins"), Unit("angle", 360.0)),
    **dict.fromkeys(("full turn", "full turns", "full rotations", "full rotation", "complete turns", "whole turns"), Unit("angle", 360.0)),
    **dict.fromkeys(("time", "times"), Unit("count")),
    **dict.fromkeys(("circle", "circles", "loop", "loops", "lap", "laps"), Unit("shape_count")),
    **dict.fromkeys(("m/s", "meters per second", "metres per second", "meter per second", "metre per second", "m per second",
                     "meters a second", "metres a second"), Unit("speed")),
    **dict.fromkeys(("hand", "hands", "arm", "arms"), Unit("hands")),
}  # fmt: skip
SHAPES: dict[str, str] = {
    "circle": "circle", "full circle": "full_circle", "complete circle": "full_circle", "loop": "circle", "arc": "arc", "curve": "arc",
    "semicircle": "semicircle", "semi circle": "semicircle", "half circle": "semicircle", "half a circle": "semicircle",
    "quarter circle": "quarter_circle", "quarter of a circle": "quarter_circle", "figure 8": "figure_eight",
    "figure of 8": "figure_eight", "square": "square", "a quarter circle": "quarter_circle", "a quarter of a circle": "quarter_circle",
    "a half circle": "semicircle", "a semicircle": "semicircle", "a full circle": "full_circle", "an arc": "arc", "a circle": "circle",
}  # fmt: skip
ANGLES: dict[str, str] = {
    "quarter turn": "90", "a quarter": "90", "quarter rotation": "90", "quarter of a turn": "90", "half turn": "180",
    "half a turn": "180", "half rotation": "180", "half a rotation": "180", "half spin": "180", "full turn": "360",
    "full rotation": "360", "complete turn": "360", "complete rotation": "360", "whole turn": "360", "full spin": "360",
    "all the way around": "360", "all the way round": "360", "around": "around", "round": "around",
    "about face": "180", "u turn": "180", "uturn": "180", "the other way": "180", "the opposite way": "180",
    "the other direction": "180", "the opposite direction": "180",
}  # fmt: skip
SPEEDS: dict[str, str] = {
    **_tagged("slow slowly carefully gently cautiously leisurely gradually steadily", "slow"),
    **_tagged("fast quickly quick briskly rapidly swiftly speedily hurriedly", "fast"),
    "as fast as you can": "fast", "as quickly as you can": "fast", "as fast as possible": "fast", "in a hurry": "fast",
    "as slowly as you can": "slow", "as slow as you can": "slow", "as slowly as possible": "slow", "take your time": "slow",
    "at a slow pace": "slow", "at a fast pace": "fast", "at normal speed": "normal", "at a normal pace": "normal",
    "at your normal speed": "normal",
}  # fmt: skip
VAGUE = ("a little", "a little bit", "a bit", "a tad", "slightly", "a touch", "a short way", "a little way")
BODY: dict[str, str] = {"hand": "hand", "hands": "hand", "arm": "arm", "arms": "arm", "finger": "hand", "palm": "hand"}
HANDS: dict[str, str] = {"both": "both", "the other": "other", "the other 1": "other", "other": "other", "other 1": "other"}
STATES: dict[str, str] = {
    **dict.fromkeys(("up", "raised", "lifted", "high", "in the air", "up high", "overhead", "above your head", "up in the air",
                     "aloft"), "raise"),
    **dict.fromkeys(("crossed", "folded", "across your chest", "across the chest"), "arms_crossed"),
    **dict.fromkeys(("on your hips", "on the hips", "on hips", "on my hips", "akimbo"), "hands_on_hips"),
    **dict.fromkeys(("down", "at your sides", "by your sides", "at your side", "to your sides", "back down"), "lower"),
    **dict.fromkeys(("out", "outstretched", "extended", "out in front", "in front of you"), "reach"),
}  # fmt: skip
PLACES = (
    "start", "the start", "starting point", "the starting point", "starting position", "the starting position",
    "the beginning", "beginning", "where you started", "where you began", "where you were", "where you came from",
    "your starting point", "your starting position", "the origin", "origin", "your start", "start position",
    "your original position", "the original position", "your starting spot", "the starting spot", "where it started",
)  # fmt: skip
FILLERS = (
    "please", "pls", "kindly", "could you", "can you", "would you", "will you", "would you mind", "do you mind",
    "would you be so kind as to", "i'd like you to", "i would like you to", "i want you to", "i need you to",
    "i'd love for you to", "i'd love you to", "go ahead and", "if you can", "if you could", "if possible", "thanks",
    "thank you", "thank you very much", "now", "right now", "right away", "just", "let's", "let us", "try to", "try and",
    "make sure to", "make sure you", "be sure to", "hey", "hi", "hello", "ok", "okay", "alright", "all right", "well",
    "so", "um", "uh", "oh", "robot", "buddy", "g1", "also", "too", "as well", "for me", "yourself", "again", "more",
    "another", "exactly", "about", "roughly", "approximately", "around about", "some", "there", "here",
    "in place", "on the spot", "you", "you're", "you are", "it", "then", "next", "first", "finally", "lastly",
    "and then", "i'd like", "i want", "go on", "quickly now", "by", "of", "for", "the", "a", "an",
)  # fmt: skip
GRAMMAR = (
    "to", "the", "your", "my", "its", "of", "for", "by", "in", "on", "at", "with", "a", "an", "into", "toward",
    "towards", "over", "it", "them", "that", "this", "those", "these", "me", "us", "everyone", "everybody", "all",
    "each", "way", "direction", "along", "through", "starting", "start with", "starting with", "going", "beginning with",
    "distance", "total", "altogether", "in total", "pace", "speed", "size", "wide",
    "hello", "hi", "hey", "goodbye", "bye", "hand", "like", "same", "pose", "position", "one", "side", "up", "out",
)  # fmt: skip
SEQ = (
    "then", "and then", "after that", "after this", "afterwards", "afterward", "next", "and next", "finally",
    "and finally", "lastly", "and lastly", "followed by", "once that's done", "once that is done", "once done",
    "when you're done", "when you are done", "when done", "and after that", "after which",
)  # fmt: skip
SIM = (
    "while", "whilst", "as", "as you", "at the same time", "at the same time as", "and at the same time", "simultaneously",
    "meanwhile", "while you", "whilst you", "all the while", "during", "and meanwhile",
)  # fmt: skip
ORDINALS = ("first", "first of all", "second", "secondly", "third", "thirdly", "fourth", "to start", "to begin", "to start with",
            "to begin with", "at first", "last", "last of all")  # fmt: skip
CONDITIONS = (
    "if", "unless", "until", "till", "untill", "when", "whenever", "as soon as", "in case", "once you", "once someone",
    "once it", "before you", "after you", "provided", "as long as", "so long as", "otherwise", "depending",
)  # fmt: skip
NEGATIONS = ("don't", "do not", "dont", "never", "not", "no", "without", "nothing")
CORRECTIONS = ("no wait", "never mind", "nevermind", "scratch that", "i mean", "actually no", "cancel that", "forget it",
               "forget that", "or rather", "sorry i meant", "actually")  # fmt: skip

# Things it cannot do, by reason key (the reasons are in `REASONS`).
UNSUPPORTED: dict[str, str] = {
    **_tagged("jump jumps jumping hop hops hopping leap leaps leaping bounce bouncing", "jump"),
    **_tagged("run runs running sprint sprinting jog jogging race racing dash dashing", "run"),
    **_tagged("sit sitting seat seated", "sit"),
    **_tagged("lie lying lay laying sleep sleeping nap", "lie"),
    **_tagged("crawl crawling", "crawl"),
    **_tagged("kick kicks kicking", "kick"),
    **_tagged("punch punches punching strike strikes striking hit hits hitting slap slapping box boxing fight "
                    "fighting attack attacking chop karate", "strike"),
    **_tagged("climb climbing stairs staircase upstairs downstairs ladder", "climb"),
    **_tagged("dance dances dancing boogie twerk twerking", "dance"),
    **_tagged("flip flips backflip backflips frontflip somersault somersaults cartwheel cartwheels handstand", "flip"),
    **_tagged("fly flying swim swimming", "fly"),
    **_tagged("pushup pushups push-ups squat squats squatting kneel kneeling crouch crouching bow bows bowing lunge lunges "
                    "curtsy stretch stretching exercise yoga", "exercise"),
    **_tagged("nod nodding look looking glance glancing eyes", "head"),
    **_tagged("lean leaning bend bending twist twisting tilt tilting torso waist hips body shoulders chest", "torso"),
    **_tagged("say saying speak speaking talk talking sing singing tell shout shouting yell whisper laugh smile count "
                    "counting", "speech"),
    **_tagged("clap clapping salute saluting thumbs handshake shrug shrugging hug hugging kiss flex flexing beckon snap "
                    "scratch high-five applaud applause", "other_gesture"),
    **_tagged("pick grab grabbing carry carrying fetch bring bringing catch catching push pushing pull pulling press touch "
                    "touching open close door drawer kick-off", "manipulate"),
    **_tagged("balance balancing", "balance"),
    **_tagged("tiptoe tiptoes tiptoeing march marching stomp stomping limp limping strut strutting swagger sneak "
                    "sneaking creep creeping waddle waddling prance prancing skip skipping gallop galloping zigzag zigzagging "
                    "moonwalk moonwalking shimmy slide sliding glide gliding parade", "style"),
    **_tagged("follow following find search see seeing watch watching hear spot detect someone somebody anyone anybody "
                    "person people", "perception"),
    **_tagged("before after", "order"),
    "shake hands": "other_gesture", "shake your hand": "other_gesture", "high five": "other_gesture", "blow a kiss": "other_gesture",
    "thumbs up": "other_gesture", "peace sign": "other_gesture", "shake your head": "head", "your head": "head",
    "the head": "head", "its head": "head",
    "on one leg": "balance", "on one foot": "balance", "on your toes": "style", "like a": "style", "in the style of": "style",
    "come here": "perception", "come to me": "perception", "towards me": "perception", "toward me": "perception",
    "to me": "perception", "over here": "perception", "push ups": "exercise", "sit ups": "exercise", "jumping jacks": "jump",
    "in place": "in_place", "on the spot": "in_place", "forever": "unbounded", "far away": "unbounded", "far": "unbounded",
    "as far as you can": "unbounded", "keep going": "unbounded", "indefinitely": "unbounded", "nonstop": "unbounded",
    "non stop": "unbounded", "endlessly": "unbounded", "lower body": "torso", "upper body": "torso",
}  # fmt: skip
# "in place" / "on the spot" is fine with a turn or a gesture ("turn in place", "wave on the spot"): `behaviours` decides.

REASONS: dict[str, str] = {
    "jump": "jumping (both feet off the ground) is beyond this robot's planner",
    "run": "running is beyond the walking policy (at most 0.8 m/s)",
    "sit": "sitting needs whole-body contacts this planner does not plan",
    "lie": "lying down needs whole-body contacts this planner does not plan",
    "crawl": "crawling needs hands on the ground, which this planner does not plan",
    "kick": "kicking (standing on one foot) is beyond this robot's planner",
    "strike": "striking, punching and fighting are not among its gestures",
    "climb": "stairs and climbing are beyond this robot's planner (flat ground only)",
    "dance": "dancing is not among its behaviours",
    "flip": "flips are beyond this robot's planner",
    "fly": "it only walks on flat ground",
    "exercise": "kneeling, squatting, bowing, stretching and floor exercises are beyond this robot's planner",
    "head": 'its head does not move on its own; turn the whole body instead ("turn left")',
    "torso": "the tracking policy keeps the waist and torso for balance: they are not planned on their own",
    "speech": "it cannot speak",
    "other_gesture": "its only gestures are waving, raising, pointing, reaching, crossed arms and hands on hips",
    "manipulate": "it cannot grasp, carry, push or operate objects",
    "balance": "standing on one leg is beyond this robot's planner",
    "style": "it walks one way only: gaits and styles of walking are not planned",
    "perception": "it cannot see people, places or objects; give a distance and a direction instead",
    "condition": "it cannot sense when to start or stop; give a distance, an angle or a time",
    "negation": "say what it should do, not what it should not",
    "correction": "type the request as it should run",
    "in_place": "stepping in place is not planned (it can stand still or turn in place)",
    "unbounded": "it needs to know how far: give a distance, an angle or a time",
    "order": 'say the steps in the order they should run ("walk forward, then wave")',
    "unknown": "these are not words it can act on",
}

CAPABILITIES = (
    "it can walk (forward, back, sideways, diagonally; by distance, steps or time), turn (degrees, left/right, around), "
    "follow arcs, circles and figure eights, wave or raise either or both hands, point, reach, cross its arms, put its hands "
    "on its hips (one gesture per arm, while moving too), hold a pose, stand still, return to the start, "
    "and do these one after another"
)


def _forms(base: str) -> tuple[tuple[str, bool], ...]:
    """A verb's base, -s and -ing forms (the -ing flagged), e.g. "spin" -> spin, spins, spinning."""
    if base.endswith("e") and base not in ("see",):
        ing = base[:-1] + "ing"
    elif base in ("step", "spin", "stop", "scoot", "sit", "run", "jog", "drop", "pivot"):
        ing = base + (base[-1] if base not in ("scoot", "pivot") else "") + "ing"
    else:
        ing = base + "ing"
    plural = base + ("es" if base.endswith(("sh", "ch", "s", "x")) else "s")
    return ((base, False), (plural, False), (ing, True))


def _build() -> dict[tuple[str, ...], Entry]:
    table: dict[tuple[str, ...], Entry] = {}

    def add(phrase: str, entry: Entry, replace: bool = True) -> None:
        key = tuple(phrase.split())
        if replace or key not in table:
            table[key] = entry

    for words, cat in (
        (FILLERS, Cat.FILLER), (GRAMMAR, Cat.GRAMMAR), (SEQ, Cat.SEQ), (SIM, Cat.SIM), (ORDINALS, Cat.ORDINAL),
        (CONDITIONS, Cat.CONDITION), (NEGATIONS, Cat.NEGATION), (CORRECTIONS, Cat.CORRECTION), (VAGUE, Cat.VAGUE),
        (PLACES, Cat.PLACE),
    ):  # fmt: skip
        for phrase in words:
            add(phrase, Entry(cat))
    add("and", Entry(Cat.AND))
    add("again", Entry(Cat.AGAIN))
    for light in LIGHT_VERBS.split():
        for form, gerund in _forms(light):
            add(form, Entry(Cat.LIGHT, light, gerund))
    add("did", Entry(Cat.LIGHT, "do"))
    add("made", Entry(Cat.LIGHT, "make"))
    add("took", Entry(Cat.LIGHT, "take"))
    for behaviour, verbs in VERBS.items():
        for base in verbs.split():
            for form, gerund in _forms(base):
                add(form, Entry(Cat.VERB, behaviour, gerund))
    for table_words, cat in ((DIRECTIONS, Cat.DIR), (SHAPES, Cat.SHAPE), (ANGLES, Cat.ANGLE), (SPEEDS, Cat.SPEED),
                             (BODY, Cat.BODY), (HANDS, Cat.HANDS), (STATES, Cat.STATE), (UNSUPPORTED, Cat.UNSUPPORTED)):  # fmt: skip
        for phrase, value in table_words.items():
            add(phrase, Entry(cat, value))
    for phrase, behaviour in PHRASE_VERBS.items():
        gerund = phrase.split()[0].endswith("ing")
        add(phrase, Entry(Cat.VERB, behaviour, gerund))
    for word in ("radius",):
        add(word, Entry(Cat.RADIUS))
    add("diameter", Entry(Cat.DIAMETER))
    add("wide", Entry(Cat.DIAMETER))
    add("across", Entry(Cat.DIAMETER))
    return table


LEXICON: dict[tuple[str, ...], Entry] = _build()
LONGEST = max(len(k) for k in LEXICON)
