"""How well an executed text plan did: order of the clauses, smoothness of their joins.

`order_assignment` follows Text2BFM's order accuracy with a frozen embedder: each executed
segment is described from its measured motion only (displacement, heading change, the
gestures the detector saw) as a short sentence, embedded by the frozen sentence encoder,
and matched to the clause whose embedding is most similar. A clause is embedded from what
it was resolved to, in the same words (`clause_caption`): raw phrasing ("back up one
meter") lands further from "walk backward 1.0 meters" in MiniLM's space than an unrelated
clause with shared words does, which would measure the encoder, not the execution. The
prompt is in order when segment i matches clause i for every i (the assignment is
increasing and complete). Clauses with the same caption are interchangeable: a tie goes to
the segment's own index. Captions round distances to 0.5 m and turns to 45 degrees: MiniLM
tells "2.0" from "1.0" but not reliably "1.9" from "1.0".

`transition_score` follows Text2BFM's transition measure: at each clause boundary, the
largest jump of the reference pose (root position in m and the 29 joint angles in rad, as
one vector) from one control tick to the next, and the largest jump of that per-tick
change (a velocity jump), over a window that covers the next clause's first splice and
its blend; the score is the mean of the two, averaged over the boundaries. Lower is
smoother. Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from controller.text.program import Clause
from hw import g1
from hw.types import FloatArray

Embed = Callable[[Sequence[str]], NDArray[np.floating[Any]]]  # texts -> unit vectors [N, D]

_GESTURE_PHRASES = {
    "wave_left": "wave the left hand",
    "wave_right": "wave the right hand",
    "wave_both": "wave both hands",
    "raise_left": "raise the left arm",
    "raise_right": "raise the right arm",
    "raise_both": "raise both arms",
    "reach": "reach forward with the right hand",
    "point": "point to the front right",
    "arms_crossed": "cross the arms",
    "hands_on_hips": "put the hands on the hips",
}
MIN_DISTANCE_M = 0.2  # a segment that moved less than this stood (a stop carries the robot a few centimetres)
MIN_TURN_DEG = 20.0  # ... or turned less than this did not turn
# A walk whose smaller part is at least this share of the larger is diagonal: both parts are said. Said as
# one direction, "half a meter forward and half a meter to the left" became "step to the left 0.5 meters",
# which matched a later clause better than its own.
DIAGONAL_RATIO = 0.5


def motion_caption(forward_m: float, left_m: float, heading_deg: float, gestures: Sequence[str]) -> str:
    """A sentence for a measured motion, e.g. 'walk forward 2.0 meters and turn left 90 degrees while waving the right hand'."""
    parts = []
    distance = math.hypot(forward_m, left_m)
    if distance >= MIN_DISTANCE_M:
        forward, sideways = abs(forward_m), abs(left_m)
        if min(forward, sideways) >= max(MIN_DISTANCE_M, DIAGONAL_RATIO * max(forward, sideways)):  # both parts, each its own
            parts.append(f"walk {'forward' if forward_m > 0 else 'backward'} {_half_meters(forward):.1f} meters")
            parts.append(f"step to the {'left' if left_m > 0 else 'right'} {_half_meters(sideways):.1f} meters")
        elif forward >= sideways:
            parts.append(f"walk {'forward' if forward_m > 0 else 'backward'} {_half_meters(distance):.1f} meters")
        else:
            parts.append(f"step to the {'left' if left_m > 0 else 'right'} {_half_meters(distance):.1f} meters")
    if abs(heading_deg) >= MIN_TURN_DEG:
        degrees = max(45, round(abs(heading_deg) / 45.0) * 45)
        parts.append(f"turn {'left' if heading_deg > 0 else 'right'} {degrees} degrees")
    base = " and ".join(parts) or "stand still"
    edits = [_GESTURE_PHRASES[g] for g in gestures]
    return f"{base} and {' and '.join(edits)}" if edits else base


def _half_meters(distance: float) -> float:
    return max(0.5, round(distance * 2.0) / 2.0)


def clause_caption(clause: Clause) -> str:
    """The clause as resolved, in the words of `motion_caption`: its goal displacement, turn and gestures."""
    forward, left, heading = clause.displacement
    return motion_caption(forward, left, heading, clause.gestures)


def order_assignment(segment_captions: Sequence[str], clause_captions: Sequence[str], embed: Embed) -> list[int]:
    """For each executed segment, the index of the clause whose caption embedding is closest to the segment's."""
    if not segment_captions:
        return []
    segments = embed(list(segment_captions))
    clauses = embed(list(clause_captions))
    similarity = segments @ clauses.T
    out = []
    for i, row in enumerate(similarity):
        best = int(np.argmax(row))
        if i < len(clause_captions) and clause_captions[i] == clause_captions[best]:
            best = i  # the same caption twice: either clause is this one
        out.append(best)
    return out


def in_order(assignment: Sequence[int], clauses: int) -> bool:
    """Increasing and complete: segment i matched clause i for every clause."""
    return list(assignment) == list(range(clauses))


def _pose_vector(frames: FloatArray) -> FloatArray:
    frames = np.asarray(frames, dtype=np.float64)
    return np.concatenate((frames[:, g1.QPOS_ROOT_POS], frames[:, g1.QPOS_JOINTS]), axis=1)


def boundary_jumps(frames: FloatArray, boundaries: Sequence[int], before: int = 2, after: int = 25) -> list[tuple[float, float]]:
    """(position jump, velocity jump) at each boundary tick of the reference `frames` (qpos [T, 36], one per tick).

    The window runs from `before` ticks before the boundary to `after` ticks after it (25 ticks
    at 50 Hz: 0.5 s, past the next clause's first splice, 0.13 s on, and a blend of 8 frames).
    """
    x = _pose_vector(frames)
    step = np.diff(x, axis=0)  # [T-1]: per-tick change
    out = []
    for b in boundaries:
        lo, hi = max(b - before, 1), min(b + after, len(step))
        if hi - lo < 1:
            continue
        position = float(np.max(np.linalg.norm(step[lo:hi], axis=1)))
        velocity = float(np.max(np.linalg.norm(step[lo:hi] - step[lo - 1 : hi - 1], axis=1)))
        out.append((position, velocity))
    return out


def transition_score(frames: FloatArray, boundaries: Sequence[int]) -> float | None:
    """Mean over boundaries of the mean of the position and velocity jumps (None: no boundary)."""
    jumps = boundary_jumps(frames, boundaries)
    if not jumps:
        return None
    return float(np.mean([(p + v) / 2.0 for p, v in jumps]))
