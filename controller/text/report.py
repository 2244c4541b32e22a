"""The report of an executed text plan: per clause what was measured, and the whole run's order and smoothness.

Every measured figure comes from the executed motion; the gestures from a detector that looks
at the executed arm motion; only `goal` is the plan's. The motion is judged by the simulator's
truth wherever one stands behind the robot (`measured_by: "truth"`), and the controller's own
view of the same displacements and headings (the estimate on hardware) is reported beside
them with the suffix `_estimate`. On a real robot the controller's view is all there is
(`measured_by: "estimate"`, no suffixed figures). A view without a base position reports its
displacements as null.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from controller.text.executor import PoseTrack, TextReference, to_frame
from controller.text.metrics import Embed, clause_caption, in_order, motion_caption, order_assignment, transition_score
from hw.types import FloatArray

Detect = Callable[[FloatArray, float], tuple[str, ...]]  # executed qpos [T, 36] at a rate (Hz) -> gesture names


def text_report(reference: TextReference, rate_hz: float, embed: Embed, detect: Detect) -> dict[str, Any]:
    """`clauses`, `total_displacement`, `total_heading_change_deg`, `order_accuracy`, `transition_score` (and what they rest on),
    judged by `measured_by`; with the truth, the same figures from the controller's view (`..._estimate`)."""
    records = [r for r in reference.records if r.end_s is not None]
    by_truth = bool(records) and all(r.truth is not None for r in records)
    clauses = []
    captions = []
    for r in records:
        gestures = detect(np.array(r.frames), rate_hz) if len(r.frames) else ()
        judged = _clause_figures(r.judged)
        goal = r.clause.displacement
        forward, left = judged["displacement"] or (0.0, 0.0)  # no base position: only plans that stay put run, the caption says so
        captions.append(motion_caption(forward, left, judged["heading_change_deg"], gestures))
        clauses.append(
            {"text": r.clause.text, "start_s": r.start_s, "end_s": r.end_s}
            | judged
            | ({f"{k}_estimate": v for k, v in _clause_figures(r.estimate).items()} if by_truth else {})
            | {
                "gestures": list(gestures),
                "goal": {"displacement": [round(goal[0], 3), round(goal[1], 3)], "heading_change_deg": round(goal[2], 1),
                         "gestures": list(r.clause.gestures)},
                "timed_out": r.timed_out,
                "corrections": r.corrections,
                "motion_caption": captions[-1],
            }
        )  # fmt: skip
    texts = [clause_caption(c) for c in reference.program.clauses]
    assignment = order_assignment(captions, texts, embed) if records else []
    complete = len(records) == len(texts)
    reference_frames, boundaries = reference_with_boundaries(reference)
    score = transition_score(reference_frames, boundaries) if len(reference_frames) else None
    totals = _total_figures([r.judged for r in records])
    return (
        {"prompt": reference.program.prompt, "measured_by": "truth" if by_truth else "estimate", "clauses": clauses,
         "clauses_planned": len(texts)}
        | totals
        | ({f"{k}_estimate": v for k, v in _total_figures([r.estimate for r in records]).items()} if by_truth else {})
        | {
            "order_assignment": assignment,
            "order_accuracy": 1.0 if complete and in_order(assignment, len(texts)) else 0.0,
            "transition_score": None if score is None else round(score, 5),
            "blend_frames": reference.cfg.blend_frames,
            "corrections": sum(len(r.corrections) for r in records),
        }
    )  # fmt: skip


def _rounded(displacement: tuple[float, float] | None) -> list[float] | None:
    return None if displacement is None else [round(displacement[0], 3), round(displacement[1], 3)]


def _clause_figures(track: PoseTrack) -> dict[str, Any]:
    """One clause's `displacement` (forward, left in m; None without a base position) and `heading_change_deg`, in one view."""
    return {"displacement": _rounded(track.displacement), "heading_change_deg": round(math.degrees(track.heading_change), 1)}


def _total_figures(tracks: list[PoseTrack]) -> dict[str, Any]:
    """The whole run's `total_displacement` (in the frame of the first clause's start) and `total_heading_change_deg`, in one view."""
    total: tuple[float, float] | None = (0.0, 0.0)
    if tracks and not all(t.has_position for t in tracks):
        total = None
    elif tracks and tracks[-1].end_pose is not None:
        total = to_frame(tracks[0].start_pose, tracks[-1].end_pose)
    heading = math.degrees(sum(t.heading_change for t in tracks))
    return {"total_displacement": _rounded(total), "total_heading_change_deg": round(heading, 1)}


def reference_with_boundaries(reference: TextReference) -> tuple[FloatArray, list[int]]:
    """All clauses' reference frames in one array, and the tick index where each clause after the first begins."""
    frames: list[FloatArray] = []
    boundaries = []
    for r in reference.records:
        if frames:
            boundaries.append(len(frames))
        frames.extend(r.reference)
    return (np.array(frames) if frames else np.zeros((0, 36))), boundaries
