"""The text report's two views: the truth judges where a simulator stands behind the robot, the controller's view beside it.

The executor runs on paper (an ideal robot that does what it is told, `run_kinematic`); the
"truth" is a robot that in fact stood still elsewhere, so the two views cannot agree by accident.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from controller.planner.runtime import Planner
from controller.reference.planned import PlannedReference
from controller.text.executor import PoseTrack, TextReference
from controller.text.gesture_detector import detect_gestures
from controller.text.kinematic import run_kinematic
from controller.text.program import Clause, Motion, Program, RelativeWaypoint
from controller.text.report import text_report
from controller.tracking.presets import policy_rate_hz
from hw import g1, quat
from hw.errors import ConfigError
from hw.types import RobotState
from tests.conftest import fake_embed

WALK_TURN_WAVE = Program(
    "walk forward a meter, then turn left 90 degrees, then wave",
    (
        Clause("walk forward a meter", Motion((RelativeWaypoint(1.0, 0.0, 0.0),))),
        Clause("turn left 90 degrees", Motion((RelativeWaypoint(0.0, 0.0, 90.0),))),
        Clause("wave", None, ("wave_right",), 2.0),
    ),
)
WAVE = Program("wave", (Clause("wave", None, ("wave_right",), 2.0),))
RATE_HZ = policy_rate_hz("fastsac")


@pytest.fixture(scope="module")
def planner() -> Planner:
    planner = Planner.load()
    planner.warm_up()
    return planner


def standing(x: float = 0.0, y: float = 0.0, heading: float = 0.0, has_base_position: bool = True) -> RobotState:
    qpos = np.array(g1.standing_qpos())
    return RobotState(
        time=0.0, joint_pos=qpos[g1.QPOS_JOINTS], joint_vel=np.zeros(g1.NUM_JOINTS), base_quat=quat.from_yaw(heading),
        base_ang_vel=np.zeros(3), base_pos=np.array([x, y, qpos[2]]) if has_base_position else np.zeros(3), base_lin_vel=np.zeros(3),
        has_base_position=has_base_position,
    )  # fmt: skip


def _report(planner: Planner, truth: Callable[[], RobotState | None]) -> dict[str, Any]:
    reference = TextReference(WALK_TURN_WAVE, PlannedReference(planner.plan), truth=truth)
    try:
        run_kinematic(reference, RATE_HZ, max_seconds=60.0)
    finally:
        reference.close()
    return text_report(reference, RATE_HZ, fake_embed, detect_gestures)


def test_the_truth_judges_and_the_controllers_view_stands_beside_it(planner: Planner) -> None:
    """The controller believed it walked a meter, turned and waved; the truth saw a robot that stood still: the report says so."""
    report = _report(planner, lambda: standing(2.0, 3.0, 0.5))
    assert report["measured_by"] == "truth"
    walk, turn, wave = report["clauses"]
    assert walk["displacement"] == [0.0, 0.0] and turn["heading_change_deg"] == 0.0 and wave["gestures"] == []
    assert walk["displacement_estimate"] == pytest.approx([1.0, 0.0], abs=0.08)  # the follower's tolerance
    assert turn["heading_change_deg_estimate"] == pytest.approx(90.0, abs=12.0)
    assert report["total_displacement"] == [0.0, 0.0] and report["total_heading_change_deg"] == 0.0
    assert report["total_displacement_estimate"] == pytest.approx([1.0, 0.0], abs=0.15)
    assert report["total_heading_change_deg_estimate"] == pytest.approx(90.0, abs=12.0)
    assert walk["motion_caption"] == "stand still"  # the order is judged from what the truth saw


def test_without_a_truth_the_controllers_view_is_all_there_is(planner: Planner) -> None:
    """A real robot: `Backend.truth()` is None; the figures are the controller's, labelled so, with nothing beside them."""
    report = _report(planner, lambda: None)
    assert report["measured_by"] == "estimate"
    keys = set(report) | {key for clause in report["clauses"] for key in clause}
    assert not [key for key in keys if key.endswith("_estimate")]
    walk, turn, _ = report["clauses"]
    assert walk["displacement"] == pytest.approx([1.0, 0.0], abs=0.08)
    assert turn["heading_change_deg"] == pytest.approx(90.0, abs=12.0)


def test_a_plan_that_moves_the_base_needs_a_base_position(planner: Planner) -> None:
    """Keyed on the state, not the backend: refused where nothing gives a base position; a plan that stays put still starts."""
    no_position = standing(has_base_position=False)
    with pytest.raises(ConfigError, match=r"moves the base \('walk forward a meter'\).*no base position"):
        TextReference(WALK_TURN_WAVE, PlannedReference(planner.plan)).start(no_position)
    TextReference(WAVE, PlannedReference(planner.plan)).start(no_position)
    TextReference(WALK_TURN_WAVE, PlannedReference(planner.plan)).start(replace(no_position, has_base_position=True))


def test_a_view_without_a_base_position_has_no_displacement() -> None:
    track = PoseTrack.begin(standing(has_base_position=False))
    turned = replace(standing(has_base_position=False), base_quat=quat.from_yaw(math.radians(30.0)))
    track.measure(turned)
    track.end(turned)
    assert track.displacement is None and math.degrees(track.heading_change) == pytest.approx(30.0)
