"""A prompt resolved to a behaviour program, or refused in one line.

`plan_program(prompt, encoder)`: the grammar reads the prompt into clauses of parts
(`grammar.py`, every word from the lexicon), each part becomes a typed step by its
behaviour's handler (`behaviours.py`), and the steps of a clause are put together here into
one executable `Clause`: a base motion (a walk, a turn, a curved path, a stand, a return)
with the arm tracks layered on it (at most one gesture per arm, a pose held on from the
clause before with "keep it up"). A walk and a turn in one clause ("walk forward while
turning left") are one arc. A repetition ("twice", "do it again") is a clause of its own.

The sentence encoder decides nothing that moves. It explains a refusal: words the lexicon
does not have are refused by name, with the behaviour they are closest to ("closest to
kicking, which is beyond ..."); measured, an encoder that mapped such words to the nearest
behaviour ran a strike as a 1 m walk. So every part that runs was decided by the lexicon
(`decided_by`), and the share decided by the encoder is 0 by construction.

Limits: a clause walks at most 10 m straight or 15 m along a curve, turns at most 720
degrees, lasts at most 60 s; at most 12 clauses after repetitions; a prompt at most 500
characters of text.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from controller.text.behaviours import (
    DEFAULT_RADIUS_M,
    GESTURE_S,
    LOWER_ARMS_S,
    MAX_RADIUS_M,
    MIN_RADIUS_M,
    SPEEDS,
    YAW_RATES,
    Context,
    Gesture,
    Hold,
    Lower,
    Path,
    PhraseStep,
    Repeat,
    Return,
    Stand,
    Step,
    Turn,
    Walk,
    phrase_step,
)
from controller.text.grammar import MAX_PROMPT_CHARS, ClauseText, UnknownWords, read, refuse
from controller.text.lexicon import CAPABILITIES
from controller.text.program import GESTURE_ARMS, Arc, Clause, Curve, Motion, Program, PromptRefused, RelativeWaypoint

MAX_CLAUSE_WALK_M = 10.0
MAX_CLAUSE_PATH_M = 15.0
MAX_TURN_DEG = 720.0
MAX_DURATION_S = 60.0
MAX_CLAUSES = 12
SPLIT_TURN_ABOVE_DEG = 150.0
TURN_PIECE_DEG = 120.0
AT_START_M = 0.05  # a return from closer than this is a short stand

Pose = tuple[float, float, float]  # forward, left (m), heading (deg) in the frame of the program's start


class TextEncoder(Protocol):
    """What the resolver needs of a sentence encoder (`controller.text.encoder.SentenceEncoder`)."""

    def embed(self, texts: Sequence[str]) -> NDArray[np.float32]: ...


def check_prompt(prompt: object) -> str:
    """The prompt as text, stripped; PromptRefused for an empty one, one too long, or one that is not text."""
    if isinstance(prompt, bytes):
        try:
            prompt = prompt.decode("utf-8")
        except UnicodeDecodeError:
            raise PromptRefused(f"cannot plan a prompt that is not UTF-8 text; {CAPABILITIES}") from None
    if not isinstance(prompt, str):
        raise PromptRefused(f"cannot plan a prompt of type {type(prompt).__name__}: type the request as text; {CAPABILITIES}")
    stripped = prompt.strip()
    if not stripped:
        raise PromptRefused(f"cannot plan an empty prompt; {CAPABILITIES}")
    if len(stripped) > MAX_PROMPT_CHARS:
        raise PromptRefused(f"cannot plan a prompt of {len(stripped)} characters (at most {MAX_PROMPT_CHARS}); {CAPABILITIES}")
    printable = sum(ch.isprintable() for ch in stripped)
    if printable < len(stripped) or not any(ch.isalpha() for ch in stripped):
        raise PromptRefused(f"cannot plan a prompt with control characters or no words; type the request as text; {CAPABILITIES}")
    return stripped


def resolve(prompt: str, encoder: TextEncoder) -> tuple[Clause, ...]:
    """The prompt's clauses resolved to behaviours, in order; PromptRefused if any part cannot be planned."""
    stripped = check_prompt(prompt)
    try:
        texts = read(stripped)
    except UnknownWords as unknown:
        from controller.text.explain import explain_unknown  # noqa: PLC0415

        raise explain_unknown(unknown, encoder) from None
    if not texts:
        raise PromptRefused(f'cannot plan "{stripped}": it names no action; {CAPABILITIES}')
    ctx = Context()
    clauses: list[Clause] = []
    pose: Pose = (0.0, 0.0, 0.0)
    typed: list[list[Clause]] = []  # the clauses of each typed clause (a repetition makes several)
    for index, text in enumerate(texts):
        steps = [phrase_step(part, ctx) for part in text.parts]
        made = _clauses(text, steps, index, pose, clauses[-1] if clauses else None, typed[-1] if typed else [])
        typed.append(made)
        for clause in made:
            clauses.append(clause)
            pose = compose(pose, clause.displacement)
        if len(clauses) > MAX_CLAUSES:
            raise PromptRefused(f"cannot plan {len(clauses)} clauses or more (at most {MAX_CLAUSES} one after another); {CAPABILITIES}")
    return tuple(clauses)


def plan_program(prompt: str, encoder: TextEncoder) -> Program:
    """The prompt as a behaviour program; PromptRefused (one line) if any part cannot be planned."""
    return Program(prompt=prompt, clauses=resolve(prompt, encoder))


# --- a clause from its steps --------------------------------------------------------------------

_BASES = (Walk, Turn, Path, Stand, Return, Lower)


def _clauses(
    text: ClauseText, steps: Sequence[PhraseStep], index: int, pose: Pose, previous: Clause | None, previous_typed: list[Clause]
) -> list[Clause]:
    """The clauses one typed clause runs: one, or one per repetition."""
    shown = text.text
    repeats = [s for s in steps if isinstance(s.step, Repeat)]
    if repeats:
        if len(steps) > 1:
            raise refuse(shown, "a repetition stands on its own")
        if not previous_typed:
            raise refuse(shown, "there is nothing before it to repeat")
        times = repeats[0].step.times if isinstance(repeats[0].step, Repeat) else 1
        return [_again(c, index, shown) for _ in range(times) for c in previous_typed]
    bases = [s for s in steps if isinstance(s.step, _BASES)]
    repetitions = max((s.repetitions for s in steps), default=1)
    clause = _clause(shown, steps, bases, pose, previous, index)
    if repetitions == 1:
        return [clause]
    if clause.motion is None:
        return [_longer(clause, repetitions)]
    out, here = [], pose
    for _ in range(repetitions):
        out.append(_clause(shown, steps, bases, here, previous, index))
        here = compose(here, out[-1].displacement)
    return out


def _again(clause: Clause, index: int, text: str) -> Clause:
    return Clause(text, clause.motion, clause.gestures, clause.min_duration_s, clause.clip, dict(clause.quantities), source=index)


def _longer(clause: Clause, times: int) -> Clause:
    """A clause without a motion done N times: N times as long ("pause twice" is odd, but it means longer)."""
    q = dict(clause.quantities, repetitions=times)
    return Clause(clause.text, None, clause.gestures, clause.min_duration_s * times, None, q, clause.source)


def _clause(text: str, steps: Sequence[PhraseStep], bases: Sequence[PhraseStep], pose: Pose, previous: Clause | None, index: int) -> Clause:
    quantities: dict[str, float | str] = {}
    for s in steps:
        quantities.update(s.quantities)
    walks = [b for b in bases if isinstance(b.step, Walk)]
    turns = [b for b in bases if isinstance(b.step, Turn)]
    motion: Motion | Curve | None = None
    min_duration = 0.0
    if len(bases) == 2 and len(walks) == 1 and len(turns) == 1:
        assert isinstance(walks[0].step, Walk) and isinstance(turns[0].step, Turn)
        motion = _walk_turning(text, walks[0].step, turns[0].step)
        quantities.update(shape="walk while turning", radius_m=round(motion.arcs[0].radius_m, 3))
    elif len(bases) > 1:
        raise refuse(text, "it does one movement at a time (walk, turn, a path or stand), with gestures on top")
    elif bases:
        motion, min_duration = _base(text, bases[0].step, pose)
    gestures, seconds = _gestures(text, steps, previous, motion is None)
    if bases and isinstance(bases[0].step, Lower) and gestures:
        raise refuse(text, "it cannot lower its arms and gesture at once")
    min_duration = max(min_duration, seconds)
    _check_limits(text, motion, min_duration)
    if gestures:
        quantities["gestures"] = " ".join(gestures)
    if min_duration:
        quantities["duration_s"] = round(min_duration, 3)
    return Clause(text, motion, gestures, min_duration, None, quantities, source=index)


def _base(text: str, step: Step, pose: Pose) -> tuple[Motion | Curve | None, float]:
    """(the motion, a minimum duration) of one base step."""
    if isinstance(step, Walk):
        legs, f, lt = [], 0.0, 0.0
        for df, dl in step.legs:
            f, lt = f + df, lt + dl
            legs.append(RelativeWaypoint(f, lt, 0.0))
        return Motion(tuple(legs), step.speed_mps, YAW_RATES[step.speed]), 0.0
    if isinstance(step, Turn):
        if abs(step.degrees) > MAX_TURN_DEG:
            raise refuse(text, f"turning {abs(step.degrees):g} degrees is more than the {MAX_TURN_DEG:g} one clause may turn")
        return Motion(tuple(turn_waypoints(step.degrees)), SPEEDS[step.speed], YAW_RATES[step.speed]), 0.0
    if isinstance(step, Path):
        if step.corners:
            points = tuple(RelativeWaypoint(*c) for c in step.corners)
            return Motion(points, step.speed_mps, YAW_RATES[step.speed]), 0.0
        return Curve(tuple(Arc(r, a) for r, a in step.arcs), step.speed_mps), 0.0
    if isinstance(step, Stand):
        return None, step.seconds
    if isinstance(step, Lower):
        return None, LOWER_ARMS_S
    if isinstance(step, Return):
        back = _return(pose)
        if back is None:
            return None, 0.5
        return Motion((back,), SPEEDS[step.speed], YAW_RATES[step.speed]), 0.0
    raise AssertionError(step)


def _walk_turning(text: str, walk: Walk, turn: Turn) -> Curve:
    """ "walk forward 2 m while turning left": one arc, its length the walk's and its angle the turn's."""
    if len(walk.legs) != 1 or walk.legs[0][0] <= 0 or abs(walk.legs[0][1]) > 1e-9:
        raise refuse(text, "it turns while walking forward only (an arc)")
    radius = walk.legs[0][0] / math.radians(abs(turn.degrees)) if walk.distance_stated else DEFAULT_RADIUS_M
    if not MIN_RADIUS_M <= radius <= MAX_RADIUS_M:
        raise refuse(text, f"that is an arc of radius {radius:.2g} m, outside the {MIN_RADIUS_M:g} to {MAX_RADIUS_M:g} m it follows")
    return Curve((Arc(radius, turn.degrees),), min(walk.speed_mps, radius * YAW_RATES["fast"]))


def _gestures(text: str, steps: Sequence[PhraseStep], previous: Clause | None, alone: bool) -> tuple[tuple[str, ...], float]:
    """The clause's arm tracks (one gesture per arm) and how long they ask the clause to last."""
    names: list[str] = []
    seconds = 0.0
    for s in steps:
        step = s.step
        if isinstance(step, Hold):
            if previous is None or not previous.gestures:
                raise refuse(s.text, "there is no pose before it to hold")
            names += [g for g in previous.gestures if g not in names]
            seconds = max(seconds, step.seconds if step.seconds is not None else (GESTURE_S if alone else 0.0))
        elif isinstance(step, Gesture):
            if s.open_ended and alone:
                raise refuse(s.text, "it needs to know for how long: give a time, or a movement to do it during")
            names += list(step.names)
            seconds = max(seconds, step.seconds if step.seconds is not None else (GESTURE_S if alone else 0.0))
    names = _other_arm(text, names)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            shared = " and ".join(sorted(GESTURE_ARMS[a] & GESTURE_ARMS[b]))
            if shared:
                raise refuse(text, f"one gesture per arm at a time ({a} and {b} both move the {shared} arm)")
    return tuple(names), seconds


def _other_arm(text: str, names: list[str]) -> list[str]:
    """ "wave with one hand while raising the other": "other" is the arm the clause's other gestures leave free."""
    out = []
    for name in names:
        if not name.endswith("_other"):
            out.append(name)
            continue
        used = set().union(*(GESTURE_ARMS[n] for n in names if not n.endswith("_other")))
        free = {"left", "right"} - used
        if len(free) != 1 or len(used) != 1:
            raise refuse(text, '"the other" arm needs one arm named before it')
        out.append(name.replace("_other", f"_{free.pop()}"))
    return out


def _check_limits(text: str, motion: Motion | Curve | None, min_duration: float) -> None:
    if min_duration > MAX_DURATION_S:
        raise refuse(text, f"{min_duration:g} s is longer than the {MAX_DURATION_S:g} s one clause may last")
    if isinstance(motion, Curve):
        if motion.length_m > MAX_CLAUSE_PATH_M + 1e-9:
            raise refuse(text, f"a path of {motion.length_m:.3g} m is more than the {MAX_CLAUSE_PATH_M:g} m one clause may follow")
        if motion.length_m / motion.speed_mps > MAX_DURATION_S:
            raise refuse(text, f"the path takes {motion.length_m / motion.speed_mps:.0f} s, longer than {MAX_DURATION_S:g} s")
    elif motion is not None:
        length = path_length(motion.waypoints)
        if length > MAX_CLAUSE_WALK_M + 1e-9:
            raise refuse(text, f"{length:.3g} m is more than the {MAX_CLAUSE_WALK_M:g} m one clause may walk")
        if length / motion.speed_mps > MAX_DURATION_S:
            raise refuse(text, f"walking {length:.3g} m at {motion.speed_mps:g} m/s takes longer than {MAX_DURATION_S:g} s")


# --- geometry -------------------------------------------------------------------------------------


def turn_waypoints(total_deg: float) -> list[RelativeWaypoint]:
    """Turn in place by total_deg: one waypoint, or equal pieces of at most 120 degrees (the follower turns the short way)."""
    n = 1 if abs(total_deg) <= SPLIT_TURN_ABOVE_DEG else math.ceil(abs(total_deg) / TURN_PIECE_DEG - 1e-9)
    return [RelativeWaypoint(0.0, 0.0, total_deg * (k + 1) / n) for k in range(n)]


def _return(pose: Pose) -> RelativeWaypoint | None:
    """The start position in the frame of `pose`, walked to straight without turning (None: already there)."""
    x, y, h = pose
    c, s = math.cos(math.radians(h)), math.sin(math.radians(h))
    f, lt = c * -x + s * -y, -s * -x + c * -y
    if math.hypot(f, lt) < AT_START_M:
        return None
    return RelativeWaypoint(f, lt, 0.0)


def compose(pose: Pose, step: tuple[float, float, float]) -> Pose:
    """`step` (forward, left, heading deg in the frame of `pose`) applied after `pose`."""
    c, s = math.cos(math.radians(pose[2])), math.sin(math.radians(pose[2]))
    return (pose[0] + c * step[0] - s * step[1], pose[1] + s * step[0] + c * step[1], pose[2] + step[2])


def end_pose(clauses: Sequence[Clause]) -> Pose:
    """Where the clauses end, in the frame of the robot at the start: (forward m, left m, heading deg unwrapped, + left)."""
    pose: Pose = (0.0, 0.0, 0.0)
    for clause in clauses:
        pose = compose(pose, clause.displacement)
    return pose


def path_length(waypoints: Sequence[RelativeWaypoint]) -> float:
    total, f, lt = 0.0, 0.0, 0.0
    for w in waypoints:
        total += math.hypot(w.forward_m - f, w.left_m - lt)
        f, lt = w.forward_m, w.left_m
    return total


def describe_program(program: Program) -> str:
    """The printable decomposition: one line per clause (text, quantities, end pose, gestures, duration), then the total."""
    lines = []
    pose: Pose = (0.0, 0.0, 0.0)
    for i, clause in enumerate(program.clauses, 1):
        q = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in clause.quantities.items() if k != "gestures")
        f, lt, h = clause.displacement
        pose = compose(pose, clause.displacement)
        if isinstance(clause.motion, Curve):
            how = f"curve of {len(clause.motion.arcs)} arcs, {clause.motion.length_m:.2f} m"
        else:
            how = f"{len(clause.motion.waypoints) if clause.motion else 0} waypoints"
        lines.append(
            f'{i}. "{clause.text}" | {q or "-"} | end {f:+.2f} m fwd {lt:+.2f} m left {h:+.0f} deg ({how})'
            f" | gestures {', '.join(clause.gestures) or '-'} | at least {clause.min_duration_s:.1f} s"
        )
    lines.append(f"total: {pose[0]:+.2f} m fwd {pose[1]:+.2f} m left {pose[2]:+.0f} deg")
    return "\n".join(lines)
