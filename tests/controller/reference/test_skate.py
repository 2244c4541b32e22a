"""Foot skate of the reference: planted soles sliding, by the planner's own leg chains."""

from __future__ import annotations

import numpy as np
import pytest

from controller.reference.skate import BATCH_TICKS, FootSkate, shipped_leg_chains
from hw import g1


def test_a_planted_reference_sliding_at_a_tenth_of_a_metre_per_second_skates_that_fast() -> None:
    skate = FootSkate(shipped_leg_chains())
    frame = np.array(g1.standing_qpos())
    for k in range(BATCH_TICKS + 100):  # across a batch boundary
        frame[0] = 0.1 * k / 50
        skate.record(k / 50, frame)
    assert skate.mean_mps == pytest.approx(0.1)


def test_standing_still_does_not_skate_and_lifted_soles_do_not_count() -> None:
    skate = FootSkate(shipped_leg_chains())
    frame = np.array(g1.standing_qpos())
    for k in range(50):
        skate.record(k / 50, frame)
    assert skate.mean_mps == 0.0
    lifted = FootSkate(shipped_leg_chains())
    frame[2] += 0.2  # the whole robot 20 cm up: no sole is planted
    for k in range(50):
        frame[0] = 1.0 * k / 50
        lifted.record(k / 50, frame)
    assert lifted.mean_mps == 0.0


def test_no_step_is_taken_across_a_restart() -> None:
    skate = FootSkate(shipped_leg_chains())
    frame = np.array(g1.standing_qpos())
    skate.record(0.0, frame)
    skate.record(0.02, frame)
    skate.restart()
    frame[0] = 5.0  # a new start elsewhere
    skate.record(0.04, frame)
    skate.record(0.06, frame)
    assert skate.mean_mps == 0.0
