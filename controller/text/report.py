"""The report of an executed text plan: per clause what was measured, and the whole run's order and smoothness.

Every measured figure comes from the executed motion (the robot's state each tick); the
gestures from a detector that looks at the executed arm motion; only `goal` is the plan's.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from controller.text.executor import TextReference, to_frame
from controller.text.metrics import Embed, clause_caption, in_order, motion_caption, order_assignment, transition_score
from hw.types import FloatArray

Detect = Callable[[FloatArray, float], tuple[str, ...]]  # executed qpos [T, 36] at a rate (Hz) -> gesture names


def text_report(reference: TextReference, rate_hz: float, embed: Embed, detect: Detect) -> dict[str, Any]:
    """`clauses`, `total_displacement`, `total_heading_change_deg`, `order_accuracy`, `transition_score` (and what they rest on)."""
    records = [r for r in reference.records if r.end_s is not None]
    clauses = []
    captions = []
    for r in records:
        gestures = detect(np.array(r.frames), rate_hz) if len(r.frames) else ()
        forward, left = r.displacement
        heading_deg = math.degrees(r.heading_change)
        goal = r.clause.displacement
        captions.append(motion_caption(forward, left, heading_deg, gestures))
        clauses.append(
            {
                "text": r.clause.text,
                "start_s": r.start_s,
                "end_s": r.end_s,
                "displacement": [round(forward, 3), round(left, 3)],
                "heading_change_deg": round(heading_deg, 1),
                "gestures": list(gestures),
                "goal": {"displacement": [round(goal[0], 3), round(goal[1], 3)], "heading_change_deg": round(goal[2], 1),
                         "gestures": list(r.clause.gestures)},
                "timed_out": r.timed_out,
                "motion_caption": captions[-1],
            }
        )  # fmt: skip
    texts = [clause_caption(c) for c in reference.program.clauses]
    assignment = order_assignment(captions, texts, embed) if records else []
    complete = len(records) == len(texts)
    total = to_frame(records[0].start_pose, records[-1].end_pose) if records and records[-1].end_pose else (0.0, 0.0)
    reference_frames, boundaries = reference_with_boundaries(reference)
    score = transition_score(reference_frames, boundaries) if len(reference_frames) else None
    return {
        "prompt": reference.program.prompt,
        "clauses": clauses,
        "clauses_planned": len(texts),
        "total_displacement": [round(total[0], 3), round(total[1], 3)],
        "total_heading_change_deg": round(math.degrees(sum(r.heading_change for r in records)), 1),
        "order_assignment": assignment,
        "order_accuracy": 1.0 if complete and in_order(assignment, len(texts)) else 0.0,
        "transition_score": None if score is None else round(score, 5),
        "blend_frames": reference.cfg.blend_frames,
    }


def reference_with_boundaries(reference: TextReference) -> tuple[FloatArray, list[int]]:
    """All clauses' reference frames in one array, and the tick index where each clause after the first begins."""
    frames: list[FloatArray] = []
    boundaries = []
    for r in reference.records:
        if frames:
            boundaries.append(len(frames))
        frames.extend(r.reference)
    return (np.array(frames) if frames else np.zeros((0, 36))), boundaries
