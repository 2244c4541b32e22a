"""The executor on paper (an ideal robot): clauses in order, targets from the intended poses, blended joins."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.planner.runtime import Planner
from controller.reference.planned import PlannedReference
from controller.text.executor import SETTLE_PER_WAYPOINT_S, TextReference, TextRunConfig, estimate_seconds, from_frame, to_frame
from controller.text.kinematic import run_kinematic
from controller.text.metrics import transition_score
from controller.text.program import Clause, Motion, Program, RelativeWaypoint
from controller.text.report import reference_with_boundaries
from controller.tracking.presets import policy_rate_hz

PROGRAM = Program(
    "walk forward a meter, then turn left 90 degrees, then wave",
    (
        Clause("walk forward a meter", Motion((RelativeWaypoint(1.0, 0.0, 0.0),))),
        Clause("turn left 90 degrees", Motion((RelativeWaypoint(0.0, 0.0, 90.0),))),
        Clause("wave", None, ("wave_right",), 2.0),
    ),
)


@pytest.fixture(scope="module")
def planner() -> Planner:
    planner = Planner.load()
    planner.warm_up()
    return planner


def _run(planner: Planner, blend: int | None) -> TextReference:
    reference = TextReference(PROGRAM, PlannedReference(planner.plan), TextRunConfig(blend_frames=blend))
    run_kinematic(reference, policy_rate_hz("fastsac"), max_seconds=60.0)
    reference.close()
    return reference


def test_frames_round_trip() -> None:
    origin = (1.0, 2.0, math.radians(90))
    pose = from_frame(origin, 0.5, 0.2, 0.3)
    assert pose[:2] == pytest.approx((1.0 - 0.2, 2.0 + 0.5))
    assert to_frame(origin, pose) == pytest.approx((0.5, 0.2))


def test_estimate_counts_path_turns_and_the_minimum() -> None:
    here = (0.0, 0.0, 0.0)
    assert estimate_seconds(PROGRAM.clauses[0], here, here) == pytest.approx(1.0 / 0.5 + SETTLE_PER_WAYPOINT_S)
    assert estimate_seconds(PROGRAM.clauses[1], here, here) == pytest.approx(math.radians(90) / 0.8 + SETTLE_PER_WAYPOINT_S)
    assert estimate_seconds(PROGRAM.clauses[2], here, here) == 2.0


def test_clauses_run_in_order_and_reach_their_goals(planner: Planner) -> None:
    reference = _run(planner, 8)
    records = reference.records
    assert [r.index for r in records] == [0, 1, 2] and reference.finished_at is not None
    assert all(r.end_s is not None and not r.timed_out for r in records)
    assert [records[i].end_s == records[i + 1].start_s for i in range(2)] == [True, True]
    displacement = records[0].estimate.displacement
    assert displacement is not None
    forward, left = displacement
    assert forward == pytest.approx(1.0, abs=0.08) and abs(left) < 0.08  # the follower's tolerance
    assert math.degrees(records[1].estimate.heading_change) == pytest.approx(90.0, abs=12.0)
    assert records[2].end_s - records[2].start_s >= 2.0 - 1e-6  # the wave's minimum duration
    assert reference.caption == "done"


def test_targets_come_from_the_intended_pose(planner: Planner) -> None:
    """The turn is placed where the walk was meant to end, not where it did: errors do not add up."""
    reference = _run(planner, 8)
    assert reference.records[1].intended_start == pytest.approx((1.0, 0.0, 0.0))
    assert reference.records[2].intended_start == pytest.approx((1.0, 0.0, math.radians(90.0)))


@pytest.mark.slow
def test_blended_joins_are_smoother_than_naive_ones(planner: Planner) -> None:
    scores = {}
    for blend in (8, None):
        frames, boundaries = reference_with_boundaries(_run(planner, blend))
        assert len(boundaries) == 2
        scores[blend] = transition_score(frames, boundaries)
    assert scores[8] < scores[None]


def test_blend_frames_must_be_positive() -> None:
    from hw.errors import ConfigError

    with pytest.raises(ConfigError, match="blend_frames"):
        TextRunConfig(blend_frames=0)
    assert np.isfinite(TextRunConfig().timeout_factor)
