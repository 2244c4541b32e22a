"""Clauses resolved to behaviours the stack can execute, or the prompt refused.

`plan_program(prompt, encoder)` splits the prompt (`decompose`), names each part's action
(keywords where they are unambiguous, else the nearest prototype phrase by cosine
similarity of sentence embeddings), and turns it into a `Clause`: a `Motion` of waypoints
in the clause's start frame, gestures layered on it, a minimum duration. Anything that
cannot be planned refuses the whole prompt (`PromptRefused`, one line naming the part and
what the stack can do): nothing is executed by half, nothing is improvised.

Conventions (stated, not guessed per prompt): speed 0.5 m/s, slow 0.3, fast 0.8; turning
rate 0.8 rad/s, slow 0.5, fast 1.2; a walk with no distance 1 m, "a little" 0.5 m or 30
degrees, a step 0.3 m; "turn left" with no angle 90 degrees, "turn around" 180, "spin" 360;
a turn with no side turns left; "sideways" with no side goes left; a number with no unit is
metres in a walk and degrees in a turn. A turn over 150 degrees is split into equal
waypoints of at most 120 degrees. "walk in a circle": 8 waypoints on a 0.75 m radius to the
left (right if said); "in a square": 1 m sides (or the stated distance), turning left.
"come back"/"return to the start": to the position where the program started, turning to
face it first unless it is within 20 degrees ahead, or walking backward when it is behind
and at most 1.5 m away (arrival heading: the direction of travel). A bare "go back"
returns to the start too (backward 1 m when it is already there); "go back 1 m" walks backward.
"lower your arms"/"hands down" is a 1 s stand with the arms at rest; "hold it for N s"
after a gesture keeps that gesture N s (3 s if no time). A gesture alone lasts 3 s
(a wave counted N times: N waves at 1.5 Hz plus a 0.5 s blend); "wait" with no time 2 s.
Limits: a clause walks at most 10 m, turns at most 720 degrees, lasts at most 60 s; at most
10 repetitions and 12 clauses; a prompt at most 400 characters.
"""

from __future__ import annotations

import contextlib
import math
import re
import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from controller.commands.gestures import BLEND_S
from controller.text.decompose import (
    MAX_PROMPT_CHARS,
    STEP_M,
    Quantities,
    action_phrase,
    read_quantities,
    split_clauses,
    split_parts,
)
from controller.text.program import Clause, Motion, Program, PromptRefused, RelativeWaypoint


def _words(text: str) -> frozenset[str]:
    """The whitespace-separated words of `text`."""
    return frozenset(text.split())


SPEEDS = {"slow": 0.3, None: 0.5, "fast": 0.8}  # m/s
YAW_RATES = {"slow": 0.5, None: 0.8, "fast": 1.2}  # rad/s
DEFAULT_WALK_M = 1.0
VAGUE_WALK_M = 0.5
VAGUE_TURN_DEG = 30.0
DEFAULT_TURN_DEG = 90.0
SPLIT_TURN_ABOVE_DEG = 150.0
TURN_PIECE_DEG = 120.0
CIRCLE_RADIUS_M = 0.75
CIRCLE_POINTS = 8
SQUARE_SIDE_M = 1.0
GESTURE_S = 3.0
WAVE_HZ = 1.5
DEFAULT_WAIT_S = 2.0
LOWER_ARMS_S = 1.0  # "lower your arms": a short stand, arms at rest
MAX_CLAUSE_WALK_M = 10.0
MAX_TURN_DEG = 720.0
MAX_DURATION_S = 60.0
MAX_REPETITIONS = 10
MAX_CLAUSES = 12

# Cosine similarity below which the nearest prototype is not trusted: the part is refused as not understood.
# Calibrated on the suite's paraphrases and nonsense (see tests/controller/text/test_resolve.py).
SIMILARITY_THRESHOLD = 0.52

CAPABILITIES = (
    "it can walk (forward, back, sideways, by distance or time), turn (degrees, left/right, around), "
    "wave or raise either or both hands, point, reach, cross its arms, put its hands on its hips, stand still, "
    "and do these one after another"
)

LOCOMOTION = ("walk", "turn", "wait", "return")
# Arm behaviours; a clause names the gesture with its side (`program.GESTURE_NAMES`: raise -> raise_left).
GESTURE_BEHAVIOURS = ("wave", "raise", "point", "reach", "arms_crossed", "hands_on_hips")
SUPPORTED = (*LOCOMOTION, *GESTURE_BEHAVIOURS)

# Prototype phrases per behaviour: the encoder maps a part's action phrase to the nearest one.
PROTOTYPES: dict[str, tuple[str, ...]] = {
    "walk": (
        "walk forward", "walk ahead", "move forward", "go forward", "step forward", "walk backward", "step back",
        "move to the left", "walk sideways", "stroll ahead", "advance", "head forward", "take a few steps",
        "go straight", "move ahead", "back up", "walk", "march forward", "proceed forward", "shuffle to the side",
        "walk in a circle", "go", "inch forward", "travel forward", "take a step to the right",
    ),
    "turn": (
        "turn left", "turn right", "turn around", "rotate", "spin around", "pivot", "rotate in place",
        "face the other way", "do a quarter turn", "turn to your left", "spin", "twirl around", "make a u-turn",
        "turn", "change direction", "do a full circle", "make a full turn",
    ),
    "wave": (
        "wave", "wave your hand", "wave hello", "wave goodbye", "greet us with your hand", "say hi with your hand",
        "give a wave", "wave at me", "greet people",
    ),
    "raise": (
        "raise your arms", "raise your hand", "put your hands up", "hands up", "lift your arm",
        "put your hands in the air", "arms up", "hold your arms up high",
    ),
    "point": ("point", "point ahead", "point with your finger", "point at something", "show the way with your arm"),
    "reach": ("reach forward", "reach out", "stretch your arm out", "extend your arm forward"),
    "arms_crossed": ("cross your arms", "fold your arms", "arms crossed"),
    "hands_on_hips": ("hands on hips", "put your hands on your hips", "stand with hands on your hips"),
    "wait": (
        "wait", "pause", "stand still", "stay there", "hold still", "stop", "don't move", "rest for a moment",
        "freeze", "remain in place", "stay put", "stand", "take a break",
    ),
    "return": (
        "come back", "return to where you started", "go back to the start", "return to the starting point",
        "head back to the beginning", "go back to where you were", "return",
    ),
    # Things the stack cannot do: a match refuses with the reason below.
    "jump": ("jump", "hop", "leap in the air", "jump up and down", "skip"),
    "run": ("run", "sprint", "jog", "run fast", "race"),
    "sit": ("sit down", "take a seat", "sit on the chair"),
    "lie": ("lie down", "lie on the floor", "go to sleep", "take a nap"),
    "crawl": ("crawl", "crawl on the floor", "get on all fours"),
    "kick": ("kick", "kick the ball", "kick your leg"),
    "climb": ("climb the stairs", "go up the stairs", "walk upstairs", "climb a ladder"),
    "dance": ("dance", "do a dance", "moonwalk", "boogie"),
    "manipulate": ("pick up the box", "grab the cup", "carry this", "bring me a drink", "throw the ball", "hand me that", "lift the box"),
    "door": ("open the door", "close the door", "open the drawer"),
    "flip": ("do a backflip", "do a flip", "somersault", "cartwheel", "handstand"),
    "fly": ("fly", "fly away", "take off into the sky"),
    "swim": ("swim", "go swimming"),
    "exercise": ("do push ups", "do squats", "kneel down", "bow", "do sit ups", "crouch"),
    "perception": ("follow me", "come here", "come to me", "go to the kitchen", "find the door", "look at me", "walk to the table"),
    "speech": ("say something", "talk to me", "sing a song", "tell me a joke", "speak"),
    "other_gesture": (
        "clap your hands", "salute", "give a thumbs up", "shake hands", "high five", "nod your head", "shrug", "hug me",
        "make a circle with your arms", "flap your arms", "draw a shape in the air",
    ),
    "balance": ("stand on one leg", "balance on one foot"),
    "task": (
        "cook dinner", "clean the room", "tie your shoes", "play the piano", "do yoga", "juggle", "take a photo", "drive a car",
        "ride a bike",
    ),
}  # fmt: skip

REASONS: dict[str, str] = {
    "jump": "jumping (both feet off the ground) is beyond this robot's planner",
    "run": "running is beyond the walking policy (at most 0.8 m/s)",
    "sit": "sitting needs whole-body contacts this planner does not plan",
    "lie": "lying down needs whole-body contacts this planner does not plan",
    "crawl": "crawling needs hands on the ground, which this planner does not plan",
    "kick": "kicking (standing on one foot) is beyond this robot's planner",
    "climb": "stairs and climbing are beyond this robot's planner (flat ground only)",
    "dance": "dancing is not among its behaviours",
    "manipulate": "it cannot grasp, carry or throw objects",
    "door": "it cannot grasp or operate doors and drawers",
    "flip": "flips are beyond this robot's planner",
    "fly": "it cannot fly",
    "swim": "it cannot swim",
    "exercise": "kneeling, squatting, bowing and floor exercises are beyond this robot's planner",
    "perception": "it cannot see people, places or objects; give a distance and a direction instead",
    "speech": "it cannot speak",
    "other_gesture": "its only gestures are waving, raising, pointing, reaching, crossed arms and hands on hips",
    "balance": "standing on one leg is beyond this robot's planner",
    "task": "it only moves its body: walking, turning and arm gestures",
    "until": "it cannot sense when to stop; give a distance or a time",
    "head": 'its head does not move on its own; turn the whole body instead ("turn left")',
    "style": "it walks, turns and gestures one way only: gaits and styles are not planned",
    "in_place": "stepping in place is not planned (it can stand still)",
    "unknown": "not an action this planner knows",
}

# Unambiguous words for things it cannot do (checked before anything else).
_UNSUPPORTED_KEYWORDS: tuple[tuple[str, str], ...] = (
    (r"\b(?:back|front)?flips?\b|\bsomersaults?\b|\bcartwheels?\b|\bhandstands?\b", "flip"),
    (r"\bjump\w*|\bhop\b|\bhopping\b|\bleap\w*", "jump"),
    (r"\b(?:run|runs|running|sprint\w*|jog\w*)\b", "run"),
    (r"\bsit\b|\bsitting\b|\bsit down\b|\btake a seat\b", "sit"),
    (r"\b(?:lie|lay|lying|laying) (?:down|on)\b|\bnap\b|\bsleep\b", "lie"),
    (r"\bcrawl\w*", "crawl"),
    (r"\bkick\w*", "kick"),
    (r"\bclimb\w*|\bstairs?\b|\bstaircase\b|\bupstairs\b|\bdownstairs\b|\bladder\b", "climb"),
    (r"\bdanc\w*|\bmoonwalk\w*|\bboogie\b|\btwerk\w*", "dance"),
    (r"\bpick (?:\w+ )?up\b|\bgrab\w*|\bcarry\w*|\bfetch\w*|\bbring\b|\bthrow\w*|\bcatch\w*|\bhand me\b|\bgive me\b(?! a wave)|"
     r"\b(?:lift|hold) (?:the|a|an)\b", "manipulate"),
    (r"\bdoors?\b|\bdrawers?\b|\bopen\b", "door"),
    (r"\bfly\b|\bflying\b", "fly"),
    (r"\bswim\w*", "swim"),
    (r"\bpush ?ups?\b|\bsit ?ups?\b|\bsquat\w*|\bkneel\w*|\bcrouch\w*|\bbow\b|\blunges?\b", "exercise"),
    (r"\buntil\b|\btill\b", "until"),
    (r"\b(?:turn|move|tilt|shake|nod|rotate) (?:your |the )?head\b|\bhead (?:left|right|up|down)\b|"
     r"\blook (?:left|right|up|down|around)\b", "head"),
    (r"\blike an? \w+|\bin the style of\b|\bon (?:your |its |my )?(?:hands|knees|toes|tiptoes?|all fours)\b|\bon tiptoe\b|"
     r"\bzigzag\w*", "style"),
    (r"^(?:walk|step|march|move|stomp)\w* (?:in place|on the spot)\b", "in_place"),
    (r"\bshake (?:your |the )?(?:hips|body|booty|butt)\b|\bwiggle\w*", "dance"),
    (r"^(?!wav|greet|say|point|hello|hi\b)\w+.*\b(?:to|towards?|into|around|over to|up to|through|across) "
     r"(?:the|a|an|that|this|my|our|his|her|their) "
     r"(?!left\b|right\b|front\b|side\b|start\w*\b|beginning\b|origin\b|back\b|other\b|opposite\b|same\b|original\b|initial\b)\w+",
     "perception"),
    (r"\bfollow\b|\bcome here\b|\bcome to me\b|\btowards? (?:me|us|him|her|them)\b|\blook (?:at|for)\b|\bfind\b|\bsearch\b",
     "perception"),
    (r"\b(?:sing|talk|speak|tell|shout|laugh|smile)\b|\bsay (?!hi\b|hello\b|hey\b|bye\b|goodbye\b)", "speech"),
    (r"\bclap\w*|\bsalut\w*|\bthumbs? up\b|\bshake hands\b|\bhandshake\b|\bhigh five\b|\bnod\w*|\bshrug\w*|\bhug\b|\bblow a kiss\b",
     "other_gesture"),
    (r"\bon one (?:leg|foot)\b|\bbalance\b", "balance"),
)  # fmt: skip

_RETURN_RE = re.compile(
    r"\b(?:go|walk|head|get|move|come)\w* to (?:the )?(?:start\w*|beginning|origin)\b|"
    r"\bcome back\b|\breturn\w*|\bback to (?:the )?(?:start\w*|beginning|origin|where)|\bwhere you (?:started|began|were|came from)\b|"
    r"\b(?:starting|original|initial) (?:point|position|spot|place|pose)\b|\bgo home\b"
)
_REPEAT_RE = re.compile(r"^(?:do (?:it|that|this|the same(?: thing)?)|repeat(?: it| that| this)?)(?: again)?\b|^again\b")
_GESTURE_RE = re.compile(r"\b(?:wave|waving|raise|raising|lift|lifting|point|pointing|reach|reaching|hands?|arms?)\b")
# A prompt that corrects itself is not guessed at.
_SELF_CORRECTION_RE = re.compile(
    r"\bno wait\b|\bnever ?mind\b|\bscratch that\b|\bi mean\b|\bactually no\b|\bcancel that\b|\bforget (?:it|that)\b"
)
_LOWER_ARMS_RE = re.compile(
    r"\b(?:lower|drop|relax|rest) (?:your |both |the )?(?:left |right )?(?:arms?|hands?)\b|\b(?:arms?|hands?) down\b|"
    r"\bput (?:your |both |the )?(?:arms?|hands?) down\b|^(?:lower|drop|relax) (?:it|them)\b|^(?:put|bring) (?:it|them) (?:back )?down\b"
)
# "hold it for 3 seconds" after a gesture: the same gesture, longer.
_HOLD_RE = re.compile(r"^(?:hold|keep) (?:it|them|that|this|that pose|the pose|your (?:arms?|hands?)|them up|it up)\b")
# A bare "go back"/"walk back" (no amount): back to the start; "step back" is one step backward.
_BARE_BACK_RE = re.compile(r"^(?:go|walk|head|move|come|get) back(?: again)?$")
_THERE_AND_BACK_RE = re.compile(r"\band (?:come |walk |go |head )?back(?: again)?\b")

# First-word verbs that decide the behaviour when the rest of the part is plain.
_VERBS: dict[str, str] = {}
for _behaviour, _verb_words in {
    "walk": "walk walks walking go going move moving step steps stepping head stroll strolling advance march marching proceed "
    "travel wander shuffle strafe sidestep scoot inch back take saunter amble come get",
    "turn": "turn turns turning rotate rotating spin spinning pivot pivoting twirl swivel face",
    "wave": "wave waves waving",
    "raise": "raise raising lift lifting hands arms put putting hold holding",
    "point": "point points pointing",
    "reach": "reach reaching extend stretch",
    "arms_crossed": "cross crossing fold folding",
    "wait": "wait waiting pause pausing stand standing stay staying stop halt rest freeze remain idle",
}.items():
    for _w in _verb_words.split():
        _VERBS[_w] = _behaviour

# Words a keyword decision may leave around it; anything else asks the encoder for a second opinion.
_PLAIN_WORDS = _words("""a an the to your my of for by in on at about around round with and it its this that there here up down out still
    left right forward forwards ahead straight onward back backward backwards reverse behind sideways side sideward
    sidewards clockwise counterclockwise anticlockwise quarter half full complete whole circle square u face way other
    opposite direction degrees degree deg m meter meters metre metres cm ft feet foot step steps pace paces stride
    strides second seconds sec secs s minute minutes min times time slowly slow quickly fast carefully gently briskly
    quick rapidly bit little tad slightly few couple more again place spot hand hands arm arms both high air hello hi
    goodbye bye finger hips hip akimbo crossed folded raised lifted outstretched extended overhead head start starting
    beginning position point where you started were began your yourself move walk turn step wave raise some distance
    small big large short long moment while all over then also""")


class TextEncoder(Protocol):
    """What the resolver needs of a sentence encoder (`controller.text.encoder.SentenceEncoder`)."""

    def embed(self, texts: Sequence[str]) -> NDArray[np.float32]: ...


@dataclass(frozen=True)
class ActionMatch:
    """Which behaviour a part names: by keyword (score 1) or by the nearest prototype phrase."""

    behaviour: str
    score: float
    prototype: str
    by: str  # "keyword" | "encoder"

    @property
    def supported(self) -> bool:
        return self.behaviour in SUPPORTED


_BANKS: weakref.WeakKeyDictionary[object, tuple[list[str], list[str], NDArray[np.float32]]] = weakref.WeakKeyDictionary()


def _bank(encoder: TextEncoder) -> tuple[list[str], list[str], NDArray[np.float32]]:
    """(behaviour per prototype, prototype texts, their unit embeddings), computed once per encoder."""
    try:
        cached = _BANKS.get(encoder)
    except TypeError:
        cached = None
    if cached is not None:
        return cached
    names = [name for name, phrases in PROTOTYPES.items() for _ in phrases]
    texts = [p for phrases in PROTOTYPES.values() for p in phrases]
    vectors = np.asarray(encoder.embed(texts), dtype=np.float32)
    bank = (names, texts, vectors)
    with contextlib.suppress(TypeError):  # an encoder that cannot be weakly referenced is not cached
        _BANKS[encoder] = bank
    return bank


def nearest_behaviours(phrase: str, encoder: TextEncoder, k: int = 3) -> list[ActionMatch]:
    """The k best behaviours for `phrase` by cosine similarity to their nearest prototype, best first."""
    names, texts, vectors = _bank(encoder)
    v = np.asarray(encoder.embed([phrase]), dtype=np.float32)[0]
    scores = vectors @ v
    best: dict[str, ActionMatch] = {}
    for i in np.argsort(-scores):
        name = names[i]
        if name not in best:
            best[name] = ActionMatch(name, float(scores[i]), texts[i], "encoder")
        if len(best) >= k:
            break
    return list(best.values())


def classify_action(part: str, encoder: TextEncoder) -> ActionMatch:
    """The behaviour a part (normalized text) names; `behaviour` "unknown" below the similarity threshold."""
    for pattern, name in _UNSUPPORTED_KEYWORDS:
        if re.search(pattern, part):
            return ActionMatch(name, 1.0, pattern, "keyword")
    if _RETURN_RE.search(part):
        return ActionMatch("return", 1.0, "return", "keyword")
    if _LOWER_ARMS_RE.search(part):
        return ActionMatch("wait", 1.0, "lower arms", "keyword")  # arms back to rest: a short stand
    words = re.findall(r"[a-z']+", part)
    keyword = _keyword_behaviour(part, words)
    if keyword is not None and all(w in _PLAIN_WORDS or w in _VERBS for w in words):
        return ActionMatch(keyword, 1.0, words[0] if words else "", "keyword")
    phrase = action_phrase(part) or part
    match = nearest_behaviours(phrase, encoder, k=1)[0]
    if match.score < SIMILARITY_THRESHOLD:
        return ActionMatch("unknown", match.score, match.prototype, "encoder")
    if keyword is not None and match.supported:
        return ActionMatch(keyword, match.score, match.prototype, "keyword")  # the verb decides among what it can do
    return match


def _keyword_behaviour(part: str, words: list[str]) -> str | None:
    q = read_quantities(part)
    if q.turn_deg is not None and q.distance_m is None and q.duration_s is None and q.shape is None and not _GESTURE_RE.search(part):
        return "turn"  # "do a full circle", "a quarter turn to the left", "make a u-turn"
    if re.search(r"\bhands? on (?:your |the )?hips?\b|\bakimbo\b", part):
        return "hands_on_hips"
    if re.search(r"\b(?:cross|fold)\w* (?:your |both |the )?arms\b|\barms (?:crossed|folded)\b", part):
        return "arms_crossed"
    if re.search(r"\b(?:hands?|arms?) (?:up|in the air|high|overhead|raised|lifted)\b|\breach for the sky\b", part):
        return "raise"
    if re.search(r"\bsay (?:hi|hello|hey|bye|goodbye)\b|\bwave\w*", part):
        return "wave"
    if not words:
        return None
    first = words[0]
    if first in ("hold", "holding", "put", "putting") and not re.search(r"\b(?:hands?|arms?)\b", part):
        return "wait" if re.search(r"\bstill\b|\bposition\b|\bon\b", part) else None
    if first in ("hands", "arms") and not re.search(r"\b(?:up|air|high|raised|lifted)\b", part):
        return None
    if first == "take" and not re.search(r"\bsteps?\b|\bpaces?\b|\bstrides?\b|\bwalk\b", part):
        return None
    if first in ("come", "get") and not re.search(r"\b(?:forward|back|backward|closer)\b", part):
        return None
    return _VERBS.get(first)


def _refuse(part: str, reason: str) -> PromptRefused:
    return PromptRefused(f'cannot plan "{part}": {reason}; {CAPABILITIES}')


def _turn_waypoints(total_deg: float, start: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> list[RelativeWaypoint]:
    """Turn in place by total_deg from `start` (f, l, heading): one waypoint, or equal pieces of at most 120 degrees."""
    f, lt, h = start
    n = 1 if abs(total_deg) <= SPLIT_TURN_ABOVE_DEG else math.ceil(abs(total_deg) / TURN_PIECE_DEG - 1e-9)
    return [RelativeWaypoint(f, lt, h + total_deg * (k + 1) / n) for k in range(n)]


def _rot(forward: float, left: float, heading_deg: float) -> tuple[float, float]:
    c, s = math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))
    return c * forward - s * left, s * forward + c * left


def compose(pose: tuple[float, float, float], step: tuple[float, float, float]) -> tuple[float, float, float]:
    """`step` (forward, left, heading deg in the frame of `pose`) applied after `pose` (both in the same units)."""
    dx, dy = _rot(step[0], step[1], pose[2])
    return (pose[0] + dx, pose[1] + dy, pose[2] + step[2])


def end_pose(clauses: Sequence[Clause]) -> tuple[float, float, float]:
    """Where the clauses end, in the frame of the robot at the start: (forward m, left m, heading deg unwrapped, + left)."""
    pose = (0.0, 0.0, 0.0)
    for clause in clauses:
        pose = compose(pose, clause.displacement)
    return pose


def _repeat(waypoints: list[RelativeWaypoint], times: int) -> list[RelativeWaypoint]:
    """The waypoints done `times` times, each repetition from where the previous one ended."""
    out = list(waypoints)
    end = (waypoints[-1].forward_m, waypoints[-1].left_m, waypoints[-1].heading_deg)
    pose = end
    for _ in range(times - 1):
        for w in waypoints:
            out.append(RelativeWaypoint(*compose(pose, (w.forward_m, w.left_m, w.heading_deg))))
        pose = compose(pose, end)
    return out


def _path_length(waypoints: Sequence[RelativeWaypoint]) -> float:
    total, f, lt = 0.0, 0.0, 0.0
    for w in waypoints:
        total += math.hypot(w.forward_m - f, w.left_m - lt)
        f, lt = w.forward_m, w.left_m
    return total


def _repetitions(part: str, q: Quantities) -> int:
    if q.repetitions is None:
        return 1
    if q.repetitions != int(q.repetitions) or not 1 <= q.repetitions <= MAX_REPETITIONS:
        raise _refuse(part, f"{q.repetitions:g} repetitions: a whole number from 1 to {MAX_REPETITIONS} is needed")
    return int(q.repetitions)


def _check_duration(part: str, seconds: float | None, negative: bool) -> None:
    if negative or (seconds is not None and seconds <= 0):
        raise _refuse(part, "distances, angles and times must be positive")
    if seconds is not None and seconds > MAX_DURATION_S:
        raise _refuse(part, f"{seconds:g} s is longer than the {MAX_DURATION_S:g} s one clause may last")


def _speed(part: str, q: Quantities) -> float:
    """The walking speed asked for (m/s): a stated number, else slow/normal/fast."""
    if q.speed_mps is None:
        return SPEEDS[q.speed]
    if not 0.1 <= q.speed_mps <= SPEEDS["fast"]:
        raise _refuse(part, f"{q.speed_mps:g} m/s is outside the walking speeds it plans (0.1 to {SPEEDS['fast']:g} m/s)")
    return q.speed_mps


def _walk(part: str, q: Quantities) -> tuple[list[RelativeWaypoint], dict[str, float | str]]:
    speed = _speed(part, q)
    info: dict[str, float | str] = {}
    there_and_back = bool(_THERE_AND_BACK_RE.search(part)) and "backward" in q.directions and len(q.directions) > 1
    directions = [d for d in q.directions if not (there_and_back and d == "backward")]
    if q.shape == "circle":
        radius = q.distance_m if (q.distance_m and re.search(r"\bradius\b", part)) else CIRCLE_RADIUS_M
        sign = -1.0 if q.side == "right" else 1.0
        points = []
        for k in range(1, CIRCLE_POINTS + 1):
            a = 2 * math.pi * k / CIRCLE_POINTS
            points.append(RelativeWaypoint(radius * math.sin(a), sign * radius * (1 - math.cos(a)), sign * math.degrees(a)))
        info.update(shape="circle", radius_m=radius, direction="right" if sign < 0 else "left")
        return points, info
    if q.shape == "square":
        side = q.distance_m or SQUARE_SIDE_M
        sign = -1.0 if q.side == "right" else 1.0
        corners = [(side, 0.0), (side, sign * side), (0.0, sign * side), (0.0, 0.0)]
        points = [RelativeWaypoint(f, lt, sign * 90.0 * (k + 1)) for k, (f, lt) in enumerate(corners)]
        info.update(shape="square", side_m=side, direction="right" if sign < 0 else "left")
        return points, info
    vector = {"forward": (1.0, 0.0), "backward": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}
    if q.distances:
        if any(d not in vector for d, _ in q.distances):
            raise _refuse(part, "each distance needs a direction (forward, back, left or right)")
        legs, f, lt = [], 0.0, 0.0
        for d, m in q.distances:  # "2 m forward and 1 m back": one leg after the other
            f, lt = f + vector[d][0] * m, lt + vector[d][1] * m
            legs.append(RelativeWaypoint(f, lt, 0.0))
        if q.negative or min(m for _, m in q.distances) <= 0:
            raise _refuse(part, "distances, angles and times must be positive")
        info.update(direction=" and ".join(d for d, _ in q.distances), distance_m=round(sum(m for _, m in q.distances), 3))
        return legs, info
    else:
        if q.distance_m is not None:
            distance = q.distance_m
        elif q.duration_s is not None:
            distance = speed * q.duration_s
            info["duration_s"] = q.duration_s
        elif q.vague:
            distance = VAGUE_WALK_M
        elif q.bare_number is not None and q.speed_mps is None:
            distance = q.bare_number
        elif re.match(r"(?:take (?:a|1) )?(?:step|pace|stride)\b|\bsidestep\b|\bstep\b", part) and not re.search(r"\bsteps\b", part):
            distance = STEP_M
        else:
            distance = DEFAULT_WALK_M
        ux = uy = 0.0
        for d in directions:
            if d == "sideways":
                uy += -1.0 if q.side == "right" else 1.0
            elif d in vector and not (d in ("left", "right") and "sideways" in directions):
                ux += vector[d][0]
                uy += vector[d][1]
        if re.match(r"back up\b", part) and not directions:
            ux = -1.0
        norm = math.hypot(ux, uy)
        unit = (ux / norm, uy / norm) if norm > 1e-9 else (1.0, 0.0)
        names = [n for n, (vx, vy) in vector.items() if vx * unit[0] + vy * unit[1] > 0.3]
        info["direction"] = " ".join(names) or "forward"
    if distance <= 0 or q.negative:
        raise _refuse(part, "distances, angles and times must be positive")
    if q.bare_number is not None and (q.distance_m is not None or q.duration_s is not None):
        raise _refuse(part, f"the number {q.bare_number:g} has no unit (meters, steps, seconds)")
    points = [RelativeWaypoint(unit[0] * distance, unit[1] * distance, 0.0)]
    if there_and_back:
        points.append(RelativeWaypoint(0.0, 0.0, 0.0))
        info["there_and_back"] = "yes"
    info["distance_m"] = round(distance, 3)
    return points, info


def _turn(part: str, q: Quantities) -> tuple[list[RelativeWaypoint], float]:
    if q.turn_deg is not None and q.bare_number is not None:
        raise _refuse(part, f"the number {q.bare_number:g} has no unit (degrees, turns)")
    if q.turn_deg is not None:
        degrees = q.turn_deg
    elif q.bare_number is not None:
        degrees = q.bare_number
    elif q.vague:
        degrees = VAGUE_TURN_DEG
    elif re.match(r"(?:spin|spinning|twirl)\b", part) or re.search(r"\b(?:a|1) (?:spin|twirl)\b", part):
        degrees = 360.0
    else:
        degrees = DEFAULT_TURN_DEG
    if degrees <= 0 or q.negative:
        raise _refuse(part, "distances, angles and times must be positive")
    sign = -1.0 if q.side == "right" else 1.0
    return _turn_waypoints(sign * degrees), sign * degrees


def _return(pose: tuple[float, float, float]) -> list[RelativeWaypoint]:
    """Waypoints (in the frame of `pose`) back to the program's start position."""
    x, y, h = pose
    c, s = math.cos(math.radians(h)), math.sin(math.radians(h))
    f, lt = c * -x + s * -y, -s * -x + c * -y
    distance = math.hypot(f, lt)
    if distance < 0.05:
        return []
    bearing = math.degrees(math.atan2(lt, f))
    if abs(bearing) <= 20.0:
        return [RelativeWaypoint(f, lt, 0.0)]
    if abs(bearing) > 135.0 and distance <= 1.5:
        return [RelativeWaypoint(f, lt, 0.0)]  # short way back: walk backward
    if abs(abs(bearing) - 180.0) < 1e-6:
        bearing = 180.0  # straight behind: turn left
    return [*_turn_waypoints(bearing), RelativeWaypoint(f, lt, bearing)]


_GESTURE_ARMS = {
    "wave_left": {"left"}, "wave_right": {"right"}, "wave_both": {"left", "right"},
    "raise_left": {"left"}, "raise_right": {"right"}, "raise_both": {"left", "right"},
    "reach": {"right"}, "point": {"right"}, "arms_crossed": {"left", "right"}, "hands_on_hips": {"left", "right"},
}  # fmt: skip


def _gesture_name(behaviour: str, q: Quantities) -> str:
    if behaviour in ("wave", "raise"):
        return f"{behaviour}_{q.hand or 'right'}"
    return behaviour


def _repeat_clause(text: str, previous: Clause, times: int) -> Clause:
    """ "do it again" (N times): the previous clause's behaviour once more (N times), from where it ended."""
    quantities = dict(previous.quantities, repetitions=times) if times > 1 else dict(previous.quantities)
    if previous.motion is None or times == 1:
        return Clause(text, previous.motion, previous.gestures, previous.min_duration_s * times, previous.clip, quantities)
    m = previous.motion
    motion = Motion(tuple(_repeat(list(m.waypoints), times)), m.speed_mps, m.yaw_rate)
    return Clause(text, motion, previous.gestures, previous.min_duration_s, previous.clip, quantities)


def _resolve_clause(text: str, pose: tuple[float, float, float], previous: Clause | None, encoder: TextEncoder) -> Clause:
    if _REPEAT_RE.search(text):
        if previous is None:
            raise _refuse(text, "there is nothing before it to repeat")
        return _repeat_clause(text, previous, _repetitions(text, read_quantities(text)))
    if _HOLD_RE.search(text) and previous is not None and previous.gestures:
        q = read_quantities(text)
        _check_duration(text, q.duration_s, q.negative)
        seconds = q.duration_s if q.duration_s is not None else GESTURE_S
        return Clause(text, None, previous.gestures, seconds, None, {"gestures": " ".join(previous.gestures), "duration_s": seconds})
    if _BARE_BACK_RE.search(text) and math.hypot(pose[0], pose[1]) > 0.05:
        points = _return(pose)  # "go back" after moving away: to the start (a distance makes it a backward walk)
        distance = round(math.hypot(points[-1].forward_m, points[-1].left_m), 3)
        return Clause(
            text,
            Motion(tuple(points), SPEEDS[None], YAW_RATES[None]),
            quantities={"behaviour": "return", "distance_m": distance, "speed_mps": SPEEDS[None]},
        )
    parts = split_parts(text)
    matches = [(part, classify_action(part, encoder)) for part in parts]
    for part, match in matches:
        if not match.supported:
            shown = text if len(parts) == 1 else part
            raise _refuse(shown, REASONS.get(match.behaviour, REASONS["unknown"]))
    loco = [(p, m) for p, m in matches if m.behaviour in LOCOMOTION]
    gestures = [(p, m) for p, m in matches if m.behaviour in GESTURE_BEHAVIOURS]
    if len(loco) > 1:
        raise _refuse(text, "it does one movement at a time (walk, turn or stand), with gestures on top")
    quantities: dict[str, float | str] = {}
    motion: Motion | None = None
    min_duration = 0.0
    if loco:
        part, match = loco[0]
        q = read_quantities(part)
        quantities["behaviour"] = match.behaviour
        times = _repetitions(part, q)
        _check_duration(part, q.duration_s, q.negative)
        if match.behaviour == "walk":
            points, info = _walk(part, q)
            quantities.update(info)
            points = _repeat(points, times)
            if _path_length(points) > MAX_CLAUSE_WALK_M + 1e-9:
                raise _refuse(part, f"{_path_length(points):.3g} m is more than the {MAX_CLAUSE_WALK_M:g} m one clause may walk")
            motion = Motion(tuple(points), _speed(part, q), YAW_RATES[q.speed])
        elif match.behaviour == "turn":
            points, degrees = _turn(part, q)
            if abs(degrees) * times > MAX_TURN_DEG:
                raise _refuse(part, f"turning {abs(degrees) * times:g} degrees is more than the {MAX_TURN_DEG:g} one clause may turn")
            points = _repeat(points, times)
            quantities.update(turn_deg=degrees * times, direction="left" if degrees > 0 else "right")
            motion = Motion(tuple(points), SPEEDS[q.speed], YAW_RATES[q.speed])
        elif match.behaviour == "wait":
            default_s = LOWER_ARMS_S if _LOWER_ARMS_RE.search(part) else DEFAULT_WAIT_S
            min_duration = (q.duration_s if q.duration_s is not None else default_s) * times
            _check_duration(part, min_duration, q.negative)
            quantities["duration_s"] = min_duration
        elif match.behaviour == "return":
            points = _return(pose)
            if points:
                motion = Motion(tuple(points), SPEEDS[q.speed], YAW_RATES[q.speed])
                quantities["distance_m"] = round(math.hypot(points[-1].forward_m, points[-1].left_m), 3)
            else:
                min_duration = BLEND_S
        if times > 1:
            quantities["repetitions"] = times
        if q.speed:
            quantities["speed"] = q.speed
        if match.behaviour in ("walk", "return"):
            quantities["speed_mps"] = _speed(part, q)
    names: list[str] = []
    for part, match in gestures:
        q = read_quantities(part)
        name = _gesture_name(match.behaviour, q)
        if any(_GESTURE_ARMS[name] & _GESTURE_ARMS[other] for other in names):
            raise _refuse(text, "one gesture per arm at a time")
        names.append(name)
        _check_duration(part, q.duration_s, q.negative)
        count = _repetitions(part, q)
        if q.duration_s is not None:
            seconds = q.duration_s
        elif not loco and match.behaviour == "wave" and q.repetitions is not None:
            seconds = count / WAVE_HZ + BLEND_S
            quantities["waves"] = count
        elif not loco:
            seconds = GESTURE_S * count
        else:
            seconds = 0.0
        _check_duration(part, seconds if seconds > 0 else None, False)
        min_duration = max(min_duration, seconds)
        if q.hand and match.behaviour in ("wave", "raise"):
            quantities["hand"] = q.hand
    if names:
        quantities["gestures"] = " ".join(names)
    if min_duration:
        quantities["duration_s"] = round(min_duration, 3)
    return Clause(text=text, motion=motion, gestures=tuple(names), min_duration_s=min_duration, quantities=quantities)


def resolve(prompt: str, encoder: TextEncoder) -> tuple[Clause, ...]:
    """The prompt's clauses resolved to behaviours, in order; PromptRefused if any part cannot be planned."""
    stripped = prompt.strip()
    if not stripped:
        raise PromptRefused(f"cannot plan an empty prompt; {CAPABILITIES}")
    if len(stripped) > MAX_PROMPT_CHARS:
        raise PromptRefused(f"cannot plan a prompt of {len(stripped)} characters (at most {MAX_PROMPT_CHARS}); {CAPABILITIES}")
    correction = _SELF_CORRECTION_RE.search(stripped.lower())
    if correction:
        raise PromptRefused(
            f'cannot plan "{stripped}": it corrects itself ("{correction[0]}"); type the request as it should run; {CAPABILITIES}'
        )
    texts = split_clauses(stripped)
    if not texts:
        raise PromptRefused(f'cannot plan "{stripped}": it names no action; {CAPABILITIES}')
    if len(texts) > MAX_CLAUSES:
        raise PromptRefused(f"cannot plan {len(texts)} clauses (at most {MAX_CLAUSES} one after another); {CAPABILITIES}")
    clauses: list[Clause] = []
    pose = (0.0, 0.0, 0.0)
    for text in texts:
        clause = _resolve_clause(text, pose, clauses[-1] if clauses else None, encoder)
        clauses.append(clause)
        pose = compose(pose, clause.displacement)
    return tuple(clauses)


def plan_program(prompt: str, encoder: TextEncoder) -> Program:
    """The prompt as a behaviour program; PromptRefused (one line) if any part cannot be planned."""
    return Program(prompt=prompt, clauses=resolve(prompt, encoder))


def describe_program(program: Program) -> str:
    """The printable decomposition: one line per clause (text, quantities, end pose, gestures, duration), then the total."""
    lines = []
    pose = (0.0, 0.0, 0.0)
    for i, clause in enumerate(program.clauses, 1):
        q = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in clause.quantities.items() if k != "gestures")
        f, lt, h = clause.displacement
        pose = compose(pose, clause.displacement)
        lines.append(
            f'{i}. "{clause.text}" | {q or "-"} | end {f:+.2f} m fwd {lt:+.2f} m left {h:+.0f} deg'
            f" ({len(clause.motion.waypoints) if clause.motion else 0} waypoints) | gestures {', '.join(clause.gestures) or '-'}"
            f" | at least {clause.min_duration_s:.1f} s"
        )
    lines.append(f"total: {pose[0]:+.2f} m fwd {pose[1]:+.2f} m left {pose[2]:+.0f} deg")
    return "\n".join(lines)
