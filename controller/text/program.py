"""Behaviour programs: what a prompt resolves to, one clause after the other.

A clause is a base motion (where the root goes, in the robot's frame at the clause's
start) with upper-body edits layered on it (gestures, CoMA's body-part split), a
minimum duration (a wave lasts a while even standing still) and optionally a clip of the
dataset. Everything a clause needs to run is resolved here, before anything moves: the
executor never reads text. Pure data, no MuJoCo, no torch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from hw.errors import G1Error

# Gestures a clause can ask for, by the names reports use. The executor plays them with the
# gesture library of the planner in the loop (`reference.gestures`), whose right-hand wave is "wave".
GESTURE_NAMES: tuple[str, ...] = (
    "wave_left", "wave_right", "wave_both", "raise_left", "raise_right", "raise_both",
    "reach", "point", "arms_crossed", "hands_on_hips",
)  # fmt: skip
# The arms each gesture moves: a clause has at most one gesture per arm.
GESTURE_ARMS: dict[str, frozenset[str]] = {
    "wave_left": frozenset({"left"}), "wave_right": frozenset({"right"}), "wave_both": frozenset({"left", "right"}),
    "raise_left": frozenset({"left"}), "raise_right": frozenset({"right"}), "raise_both": frozenset({"left", "right"}),
    "reach": frozenset({"right"}), "point": frozenset({"right"}), "arms_crossed": frozenset({"left", "right"}),
    "hands_on_hips": frozenset({"left", "right"}),
}  # fmt: skip
LIBRARY_NAME = {"wave_right": "wave"}  # report name -> gesture library name, where they differ


def library_gesture(name: str) -> str:
    """The gesture library's name for a report gesture name."""
    return LIBRARY_NAME.get(name, name)


class PromptRefused(G1Error, ValueError):
    """A prompt (or a part of it) that the stack cannot plan; the message names the part and what can be done."""


@dataclass(frozen=True)
class RelativeWaypoint:
    """A root target in the frame of the robot at the clause's start: forward, left (m), heading change (deg, + left)."""

    forward_m: float
    left_m: float
    heading_deg: float


@dataclass(frozen=True)
class Motion:
    """The clause's base motion: root targets reached in order, at a planar speed and turning rate.

    The last waypoint is where the clause ends. A turn of more than half a revolution is
    several waypoints (the follower turns the short way to each).
    """

    waypoints: tuple[RelativeWaypoint, ...]
    speed_mps: float = 0.5
    yaw_rate: float = 0.8  # rad/s

    def __post_init__(self) -> None:
        if not self.waypoints:
            raise ValueError("a motion needs at least one waypoint")
        if not (0.0 < self.speed_mps <= 1.5 and 0.0 < self.yaw_rate <= 2.0):
            raise ValueError(f"motion speed {self.speed_mps} m/s or turning rate {self.yaw_rate} rad/s out of range")

    @property
    def end(self) -> RelativeWaypoint:
        return self.waypoints[-1]


@dataclass(frozen=True)
class Arc:
    """A piece of a curved path: `length_m` along a circle of `radius_m`, turning `angle_deg` (+ left, - right)."""

    radius_m: float
    angle_deg: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.radius_m) and self.radius_m > 0 and math.isfinite(self.angle_deg) and self.angle_deg != 0):
            raise ValueError(f"an arc needs a positive radius and a non-zero angle, got {self.radius_m} m, {self.angle_deg} deg")

    @property
    def length_m(self) -> float:
        return self.radius_m * math.radians(abs(self.angle_deg))

    @property
    def end(self) -> RelativeWaypoint:
        """Where the arc ends in the frame of its start."""
        a = math.radians(self.angle_deg)
        sign = 1.0 if a > 0 else -1.0
        return RelativeWaypoint(self.radius_m * math.sin(abs(a)), sign * self.radius_m * (1 - math.cos(a)), self.angle_deg)


@dataclass(frozen=True)
class Curve:
    """A curved path followed as one continuous curve (a velocity with a yaw rate), never stop-and-go: arcs one after another.

    A circle is one arc of 360 degrees, a figure eight two of opposite sides, walking while
    turning one arc whose radius is the walk's length over the turn's angle.
    """

    arcs: tuple[Arc, ...]
    speed_mps: float = 0.5

    def __post_init__(self) -> None:
        if not self.arcs:
            raise ValueError("a curve needs at least one arc")
        if not 0.0 < self.speed_mps <= 1.5:
            raise ValueError(f"curve speed {self.speed_mps} m/s out of range")

    @property
    def length_m(self) -> float:
        return sum(arc.length_m for arc in self.arcs)

    @property
    def end(self) -> RelativeWaypoint:
        f = lt = h = 0.0
        for arc in self.arcs:
            e = arc.end
            c, s = math.cos(math.radians(h)), math.sin(math.radians(h))
            f, lt, h = f + c * e.forward_m - s * e.left_m, lt + s * e.forward_m + c * e.left_m, h + e.heading_deg
        return RelativeWaypoint(f, lt, h)


@dataclass(frozen=True)
class Clause:
    """One ordered part of a prompt and the behaviour it resolved to.

    `motion` None: the robot stays where it is (a gesture, a pause); a `Motion` goes through
    waypoints and stops at each, a `Curve` is followed without stopping. `gestures`: the arm
    tracks, at most one gesture per arm (CoMA's body-part split: "wave with your left hand
    while raising the right" is wave_left and raise_right). `min_duration_s`: the clause
    lasts at least this long (a wave of 3 s, "wait two seconds"); with a motion it lasts
    until the robot has arrived and this long has passed. `quantities`: what was read from
    the text (for printing and reports), e.g. {"distance_m": 2.0, "turn_deg": 90}. `source`:
    the index of the typed clause it comes from (a repetition, "twice", is a clause of its own).
    """

    text: str
    motion: Motion | Curve | None = None
    gestures: tuple[str, ...] = ()
    min_duration_s: float = 0.0
    clip: str | None = None
    quantities: dict[str, float | str] = field(default_factory=dict)
    source: int = 0

    def __post_init__(self) -> None:
        unknown = [g for g in self.gestures if g not in GESTURE_NAMES]
        if unknown:
            raise ValueError(f"unknown gestures {unknown}; valid: {', '.join(GESTURE_NAMES)}")
        shared = [(a, b) for i, a in enumerate(self.gestures) for b in self.gestures[i + 1 :] if GESTURE_ARMS[a] & GESTURE_ARMS[b]]
        if shared:
            raise ValueError(f"gestures {shared[0][0]} and {shared[0][1]} move the same arm")
        if not (math.isfinite(self.min_duration_s) and self.min_duration_s >= 0):
            raise ValueError(f"min_duration_s must be a non-negative number, got {self.min_duration_s}")

    @property
    def displacement(self) -> tuple[float, float, float]:
        """(forward m, left m, heading change deg) the clause asks for, in its start frame."""
        if self.motion is None:
            return (0.0, 0.0, 0.0)
        end = self.motion.end
        return (end.forward_m, end.left_m, end.heading_deg)


@dataclass(frozen=True)
class Program:
    """A prompt resolved: its clauses in order."""

    prompt: str
    clauses: tuple[Clause, ...]

    def __post_init__(self) -> None:
        if not self.clauses:
            raise ValueError("a program needs at least one clause")

    @property
    def typed_clauses(self) -> int:
        """How many clauses the prompt was read into (a repeated clause counts once)."""
        return len({clause.source for clause in self.clauses})
