"""Seeded random command programs for the recorded motion dataset, with their captions and gestures.

A program is a list of segments of 1.5-5 s: stand, start, stop, walk forward and backward
at varied speeds, strafe, turn in place and while walking, diagonals and speed changes,
each with a caption and, part of the time, a gesture that blends in and out at its edges.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from controller.commands.gestures import BLEND_S, GESTURE_LABELS, smoothstep
from controller.commands.velocity import CommandLimits, VelocityCommand

# --- command programs --------------------------------------------------------------------------

SEGMENT_SECONDS = (1.5, 5.0)
COMMAND_RAMP_S = 0.3  # a new command is reached linearly over this time (speed changes: the whole segment)
FORWARD = (0.2, 0.8)  # m/s
BACKWARD = (0.2, 0.6)
STRAFE = (0.15, 0.4)
TURN = (0.3, 0.8)  # rad/s
TURN_WHILE_WALKING = (0.2, 0.6)
SEGMENT_KINDS: dict[str, float] = {  # kind -> weight
    "stand": 0.14,
    "forward": 0.24,
    "backward": 0.10,
    "strafe": 0.10,
    "turn": 0.12,
    "walk_turn": 0.14,
    "diagonal": 0.06,
    "speed_change": 0.10,
}
GESTURE_SHARE = 0.55  # share of segments with a gesture
GESTURE_KEEP = 0.35  # chance a segment keeps the previous segment's gesture


GESTURE_PHRASES: dict[str, str] = {
    "wave": "waving the right hand",
    "raise_left": "with the left arm raised",
    "raise_right": "with the right arm raised",
    "raise_both": "with both arms raised",
    "reach": "reaching forward with the right hand",
    "point": "pointing to the front right",
    "arms_crossed": "with arms crossed",
    "hands_on_hips": "with hands on hips",
    "wave_left": "waving the left hand",
    "wave_both": "waving both hands",
}


def with_gesture(caption: str, gesture: int) -> str:
    """'walk forward slowly' + wave -> 'walk forward slowly while waving the right hand'."""
    if gesture == 0:
        return caption
    phrase = GESTURE_PHRASES[GESTURE_LABELS[gesture]]
    if phrase.startswith("with "):
        return f"{caption} {phrase}"
    return f"{caption} and {phrase}" if " while " in caption else f"{caption} while {phrase}"


@dataclass(frozen=True)
class Segment:
    """A stretch of an episode: the command goes from `start_cmd` to `cmd` (ramped), one gesture, one caption."""

    start: float  # s from the episode's first frame
    duration: float
    kind: str
    start_cmd: tuple[float, float, float]
    cmd: tuple[float, float, float]  # vx, vy, yaw rate
    ramp: float  # s to reach `cmd`
    gesture: int
    caption: str

    @property
    def end(self) -> float:
        return self.start + self.duration

    def command_at(self, t: float) -> tuple[float, float, float]:
        a = 1.0 if self.ramp <= 0 else min(max((t - self.start) / self.ramp, 0.0), 1.0)
        s, c = self.start_cmd, self.cmd
        return (s[0] + a * (c[0] - s[0]), s[1] + a * (c[1] - s[1]), s[2] + a * (c[2] - s[2]))


def _speed_word(speed: float, slow: float, fast: float) -> str:
    return " slowly" if speed < slow else " quickly" if speed > fast else ""


def _side(value: float) -> str:
    return "left" if value > 0 else "right"


def _draw_command(kind: str, rng: np.random.Generator, prev: tuple[float, float, float]) -> tuple[tuple[float, float, float], str]:
    """The target command of a segment kind and its caption (without the gesture)."""
    moving = any(abs(v) > 1e-6 for v in prev)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    if kind == "stand":
        return (0.0, 0.0, 0.0), "stop and stand still" if moving else "stand still"
    if kind == "forward":
        vx = float(rng.uniform(*FORWARD))
        return (vx, 0.0, 0.0), f"{'walk' if moving else 'start walking'} forward{_speed_word(vx, 0.35, 0.6)}"
    if kind == "backward":
        vx = float(rng.uniform(*BACKWARD))
        return (-vx, 0.0, 0.0), f"{'walk' if moving else 'start walking'} backward{_speed_word(vx, 0.3, 9.0)}"
    if kind == "strafe":
        vy = sign * float(rng.uniform(*STRAFE))
        return (0.0, vy, 0.0), f"step sideways to the {_side(vy)}{_speed_word(abs(vy), 0.25, 9.0)}"
    if kind == "turn":
        yaw = sign * float(rng.uniform(*TURN))
        return (0.0, 0.0, yaw), f"turn {_side(yaw)} in place{_speed_word(abs(yaw), 0.45, 0.65)}"
    if kind == "walk_turn":
        vx = float(rng.uniform(0.25, 0.7))
        yaw = sign * float(rng.uniform(*TURN_WHILE_WALKING))
        return (vx, 0.0, yaw), f"walk forward{_speed_word(vx, 0.35, 0.6)} while turning {_side(yaw)}"
    if kind == "diagonal":
        vx = float(rng.uniform(0.2, 0.5)) * (1.0 if rng.random() < 0.75 else -1.0)
        vy = sign * float(rng.uniform(0.15, 0.3))
        return (vx, vy, 0.0), f"walk {'forward' if vx > 0 else 'backward'} and to the {_side(vy)}"
    if kind == "speed_change":  # only after walking straight forward (see command_program)
        while abs((vx := float(rng.uniform(*FORWARD))) - prev[0]) < 0.25:
            pass
        return (vx, 0.0, 0.0), f"{'speed up' if vx > prev[0] else 'slow down'} while walking forward"
    raise AssertionError(kind)


def command_program(rng: np.random.Generator, duration: float, limits: CommandLimits) -> list[Segment]:
    """Segments covering [0, duration): a standing start, then random kinds with 1.5-5 s each."""
    segments: list[Segment] = []
    kinds = list(SEGMENT_KINDS)
    weights = np.array(list(SEGMENT_KINDS.values()))
    weights /= weights.sum()
    t = 0.0
    prev_cmd = (0.0, 0.0, 0.0)
    prev_gesture = 0
    while t < duration - 1e-9:
        length = float(rng.uniform(*SEGMENT_SECONDS))
        if duration - (t + length) < SEGMENT_SECONDS[0]:  # no stub at the end
            length = duration - t
        kind = "stand" if not segments else str(rng.choice(kinds, p=weights))
        if kind == "speed_change" and not (prev_cmd[0] > 0.15 and prev_cmd[1] == 0.0 and prev_cmd[2] == 0.0):
            kind = "forward"  # a speed change continues a straight forward walk
        cmd, caption = _draw_command(kind, rng, prev_cmd)
        ramp = length if kind == "speed_change" else COMMAND_RAMP_S
        clamped = limits.clamp(VelocityCommand(*cmd))
        cmd = (clamped.vx, clamped.vy, clamped.yaw_rate)
        if prev_gesture and rng.random() < GESTURE_KEEP:
            gesture = prev_gesture
        elif rng.random() < GESTURE_SHARE:
            gesture = int(rng.integers(1, len(GESTURE_LABELS)))
        else:
            gesture = 0
        segments.append(Segment(t, length, kind, prev_cmd, cmd, ramp, gesture, with_gesture(caption, gesture)))
        prev_cmd, prev_gesture = cmd, gesture
        t += length
    return segments


def gesture_weight(segments: list[Segment], i: int, t: float) -> float:
    """Blend weight of segment i's gesture at episode time t: smoothstep in after a different gesture, out before one."""
    seg = segments[i]
    w = 1.0
    if i == 0 or segments[i - 1].gesture != seg.gesture:
        w = min(w, smoothstep((t - seg.start) / BLEND_S))
    if i + 1 < len(segments) and segments[i + 1].gesture != seg.gesture:
        w = min(w, smoothstep((seg.end - t) / BLEND_S))
    return w


def gesture_starts(segments: list[Segment]) -> list[float]:
    """For each segment, when its gesture started (earlier when it continues the previous segment's)."""
    starts: list[float] = []
    for i, seg in enumerate(segments):
        starts.append(starts[-1] if i and segments[i - 1].gesture == seg.gesture else seg.start)
    return starts
