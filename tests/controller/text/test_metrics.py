"""Order and transition metrics of executed text plans."""

from __future__ import annotations

import numpy as np
import pytest

from controller.text.encoder import shared_encoder
from controller.text.metrics import (
    boundary_jumps,
    clause_caption,
    in_order,
    motion_caption,
    order_assignment,
    transition_score,
)
from controller.text.program import Clause, Motion, RelativeWaypoint
from hw import g1


def test_motion_caption_describes_what_was_measured() -> None:
    assert motion_caption(1.93, 0.04, 2.0, ()) == "walk forward 2.0 meters"
    assert motion_caption(-0.46, 0.02, 0.0, ()) == "walk backward 0.5 meters"
    assert motion_caption(0.1, 0.62, 0.0, ()) == "step to the left 0.5 meters"
    assert motion_caption(0.02, -0.03, -86.0, ()) == "turn right 90 degrees"
    assert motion_caption(0.0, 0.0, 3.0, ("wave_both",)) == "stand still and wave both hands"
    assert motion_caption(0.05, 0.0, 0.0, ()) == "stand still"  # a stop's carry is not a walk
    assert motion_caption(0.46, 0.48, 0.0, ()) == "walk forward 0.5 meters and step to the left 0.5 meters"  # diagonal
    assert motion_caption(1.9, -0.3, 0.0, ()) == "walk forward 2.0 meters"  # a drift to one side is not a diagonal


def test_clause_caption_uses_the_resolved_goal() -> None:
    clause = Clause("could you back up a meter", Motion((RelativeWaypoint(-1.0, 0.0, 0.0),)), gestures=("raise_left", "point"))
    assert clause_caption(clause) == "walk backward 1.0 meters and raise the left arm and point to the front right"


@pytest.fixture(scope="module")
def embed():
    return shared_encoder().embed


def test_order_assignment_matches_segments_to_their_clauses(embed) -> None:
    clauses = ["walk forward 2.0 meters", "turn left 90 degrees", "stand still and wave the right hand", "walk backward 0.5 meters"]
    measured = [motion_caption(1.96, 0.03, 1.0, ()), motion_caption(0.0, 0.0, 86.0, ()), motion_caption(0, 0, 0, ("wave_right",)),
                motion_caption(-0.45, 0.0, 0.0, ())]  # fmt: skip
    assignment = order_assignment(measured, clauses, embed)
    assert assignment == [0, 1, 2, 3] and in_order(assignment, 4)
    swapped = order_assignment([measured[1], measured[0], *measured[2:]], clauses, embed)
    assert not in_order(swapped, 4) and swapped[:2] == [1, 0]


def test_identical_clauses_are_interchangeable(embed) -> None:
    clauses = ["walk forward 1.0 meters", "turn left 90 degrees", "walk forward 1.0 meters"]
    assert order_assignment(["walk forward 1.0 meters", "turn left 90 degrees", "walk forward 1.0 meters"], clauses, embed) == [0, 1, 2]


def test_in_order_needs_every_clause() -> None:
    assert in_order([0, 1, 2], 3) and not in_order([0, 1], 3) and not in_order([0, 2, 1], 3)


def _walk(frames: int) -> np.ndarray:
    qpos = np.tile(g1.standing_qpos(), (frames, 1))
    qpos[:, 0] = np.arange(frames) * 0.01  # 0.5 m/s at 50 Hz
    return qpos


def test_a_jump_at_a_boundary_scores_worse_than_a_smooth_join() -> None:
    smooth = _walk(100)
    jumped = smooth.copy()
    jumped[50:, g1.QPOS_JOINTS.start + 20] += 0.8  # an arm joint jumps at the boundary
    assert transition_score(smooth, [50]) == pytest.approx(0.005, abs=1e-9)  # the walk's own step per tick, no velocity jump
    assert transition_score(jumped, [50]) > 0.5
    assert boundary_jumps(jumped, [50])[0][0] == pytest.approx(np.hypot(0.01, 0.8))
    assert transition_score(smooth, []) is None
