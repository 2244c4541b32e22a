"""The executor on paper (an ideal robot): clauses in order, targets from the intended poses, blended joins."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from controller.planner.runtime import Planner
from controller.reference.planned import PlannedReference
from controller.text.executor import (
    GESTURE_REDO_S,
    SETTLE_PER_WAYPOINT_S,
    TextReference,
    TextRunConfig,
    estimate_seconds,
    from_frame,
    to_frame,
)
from controller.text.gesture_detector import detect_gestures
from controller.text.kinematic import run_kinematic
from controller.text.metrics import transition_score
from controller.text.program import Clause, Motion, Program, RelativeWaypoint
from controller.text.report import reference_with_boundaries
from controller.tracking.presets import policy_rate_hz
from hw import quat
from hw.errors import ConfigError
from tests.conftest import IdealRobot

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


def test_a_clause_off_its_goal_is_corrected_at_most_as_often_as_configured(planner: Planner) -> None:
    """An ideal robot settles within the follower's 8 cm; asked to be within 1 mm, every moving clause is corrected once."""
    program = Program("walk forward a meter", (Clause("walk forward a meter", Motion((RelativeWaypoint(1.0, 0.0, 0.0),))),))
    for corrections in (0, 1):
        cfg = TextRunConfig(max_corrections=corrections, correct_position_m=0.001, correct_heading_deg=0.01)
        reference = TextReference(program, PlannedReference(planner.plan), cfg)
        run_kinematic(reference, policy_rate_hz("fastsac"), max_seconds=30.0)
        reference.close()
        (record,) = reference.records
        assert len(record.corrections) == corrections and reference.finished_at is not None
        for c in record.corrections:
            assert "from its goal" in c["reason"] and c["start_s"] <= c["end_s"] == record.end_s


def test_a_gesture_seen_in_the_measured_arms_needs_no_correction(planner: Planner) -> None:

    program = Program("wave with both hands", (Clause("wave with both hands", None, ("wave_both",), 3.0),))
    reference = TextReference(program, PlannedReference(planner.plan), TextRunConfig(), detect=detect_gestures)
    run_kinematic(reference, policy_rate_hz("fastsac"), max_seconds=20.0)
    reference.close()
    assert reference.records[0].corrections == [] and reference.report()["corrections"] == 0


def test_a_gesture_too_short_to_be_seen_is_held_on_once(planner: Planner) -> None:
    """Half a second of waving is under the detector's 0.9 s: the clause goes on with the wave for 3 s more."""

    program = Program("wave", (Clause("wave", None, ("wave_right",), 0.5),))
    reference = TextReference(program, PlannedReference(planner.plan), TextRunConfig(), detect=detect_gestures)
    run_kinematic(reference, policy_rate_hz("fastsac"), max_seconds=20.0)
    reference.close()
    (record,) = reference.records
    (correction,) = record.corrections
    assert "['wave_right'] not seen" in correction["reason"]
    assert record.end_s is not None and record.end_s >= 0.5 + GESTURE_REDO_S - 0.05


def test_a_program_replaced_while_it_runs_starts_from_where_the_robot_is(planner: Planner) -> None:
    """An instruction given mid-walk: the walk ends interrupted, the turn is placed from the robot's pose now (not from
    where the walk meant to end) and its first plan is asked for on the next tick, blended."""
    planned = PlannedReference(planner.plan)
    reference = TextReference(PROGRAM, planned, TextRunConfig())
    robot = IdealRobot(reference, planned)
    robot.run(2.0)
    walked = float(robot.state.base_pos[0])
    assert 0.2 < walked < 0.9 and reference.current is not None and reference.current.index == 0
    turn = Program("turn right 45 degrees", (Clause("turn right 45 degrees", Motion((RelativeWaypoint(0.0, 0.0, -45.0),))),))
    requests = planned.scheduler.counters.requests
    replaced = reference.replace_program(turn, robot.state)
    assert [r.clause.text for r in replaced] == ["walk forward a meter"] and replaced[0].interrupted and replaced[0].end_s is not None
    (record,) = reference.records
    assert record.clause is turn.clauses[0] and not record.interrupted
    assert record.intended_start == pytest.approx((walked, float(robot.state.base_pos[1]), quat.heading(robot.state.base_quat)))
    robot.tick()
    assert planned.scheduler.counters.requests == requests + 1  # asked for at once, with the segment's blend
    assert robot.until(lambda: reference.finished_at is not None, 20.0)
    assert math.degrees(record.estimate.heading_change) == pytest.approx(-45.0, abs=6.0)
    assert float(robot.state.base_pos[0]) == pytest.approx(walked, abs=0.1)  # it did not go on to the walk's end
    assert reference.caption == "done"
    # None: what runs ends, nothing follows
    reference.replace_program(PROGRAM, robot.state)
    robot.run(0.5)
    (walk,) = reference.replace_program(None, robot.state)
    assert walk.interrupted and reference.current is None and planned.follower is None and reference.finished_at is not None
    reference.close()


def test_a_program_that_walks_is_refused_without_a_base_position_and_changes_nothing(planner: Planner) -> None:
    planned = PlannedReference(planner.plan)
    reference = TextReference(PROGRAM, planned, TextRunConfig())
    robot = IdealRobot(reference, planned)
    robot.run(0.5)
    records = list(reference.records)
    blind = dataclasses.replace(robot.state, base_pos=np.zeros(3), has_base_position=False)
    with pytest.raises(ConfigError, match="no base position estimate"):
        reference.replace_program(PROGRAM, blind)
    assert reference.records == records and reference.current is not None and not reference.current.interrupted
    reference.close()
