"""The state estimator on a simulated walk, judged by the simulator's truth and contacts; its faults; its settings."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import pytest

from controller.estimation.config import default_estimator_config_path, load_estimator_config
from controller.estimation.estimator import StateEstimator
from controller.runtime import driver
from controller.runtime.run_config import RunConfig
from controller.runtime.run_plan import resolve_run
from hw.errors import ConfigError
from hw.g1 import JOINT_NAMES
from hw.types import RobotState
from sim.robot import SimRobot

Row = tuple[RobotState, RobotState, tuple[bool, bool]]  # measured, truth, the simulator's contacts


@pytest.fixture(scope="module")
def walk() -> tuple[tuple[str, ...], list[Row]]:
    """8 s of walk_turn_stop on the simulator (forward, then turning in place): each tick's state, truth and contacts."""
    plan = resolve_run(RunConfig(scenario="walk_turn_stop", duration=8.0))
    rows: list[Row] = []
    with ExitStack() as stack:
        built = driver.build(plan, stack)
        world = built.robot_side.world
        assert world is not None
        robot = built.session.backend.robot
        read = robot.read

        def recording_read() -> RobotState:
            state = read()
            if not rows or state.time > rows[-1][0].time:  # the session's read, not the truth's of the same tick
                rows.append((state, SimRobot.read(world), world.foot_contacts()))
            return state

        robot.read = recording_read  # type: ignore[method-assign]
        driver.drive(built)
        return robot.joint_names, rows


@pytest.mark.slow
def test_a_short_walk_drifts_within_the_targets(walk: tuple[tuple[str, ...], list[Row]]) -> None:
    names, rows = walk
    estimator = StateEstimator.for_g1(names)
    estimates = [estimator.update(measured) for measured, _, _ in rows]
    truth = np.array([t.base_pos[:2] for _, t, _ in rows])
    distance = float(np.sum(np.linalg.norm(np.diff(truth, axis=0), axis=1)))
    drift = float(np.linalg.norm(estimates[-1].base_pos[:2] + truth[0] - truth[-1]))
    velocity_error = np.array([e.base_lin_vel[:2] - t.base_lin_vel[:2] for e, (_, t, _) in zip(estimates, rows, strict=True)])
    assert distance > 1.5
    assert drift <= 0.01 * distance, (drift, distance)
    assert math.sqrt(np.mean(np.sum(velocity_error**2, axis=1))) <= 0.05
    assert all(e.has_base_position for e in estimates) and estimator.fault is None
    assert estimates[-1].base_quat is rows[-1][0].base_quat  # the attitude is the IMU's


@pytest.mark.slow
def test_contacts_agree_with_the_simulators(walk: tuple[tuple[str, ...], list[Row]]) -> None:
    names, rows = walk
    estimator = StateEstimator.for_g1(names)
    decided = []
    for measured, _, _ in rows:
        estimator.update(measured)
        decided.append(estimator.contacts)
    disagreements = int(np.sum(np.array(decided) != np.array([c for _, _, c in rows])))
    assert {c for _, _, c in rows} >= {(True, False), (False, True), (True, True)}  # single and double support both happen
    assert disagreements <= 0.05 * 2 * len(rows), disagreements


@pytest.mark.slow
def test_a_nan_mid_run_latches_a_fault_and_keeps_the_last_good_estimate(walk: tuple[tuple[str, ...], list[Row]]) -> None:
    names, rows = walk
    estimator = StateEstimator.for_g1(names)
    for measured, _, _ in rows[:200]:
        good = estimator.update(measured)
    bad = rows[200][0]
    out = estimator.update(dataclasses.replace(bad, imu_accel=np.array([0.0, math.nan, 9.81])))
    assert estimator.fault == "non-finite input: imu_accel"
    np.testing.assert_array_equal(out.base_pos, good.base_pos)
    later = estimator.update(rows[201][0])  # latched: good numbers do not clear it
    assert estimator.fault == "non-finite input: imu_accel"
    np.testing.assert_array_equal(later.base_pos, good.base_pos)
    estimator.reset()
    assert estimator.fault is None
    np.testing.assert_allclose(estimator.update(rows[202][0]).base_pos[:2], [0.0, 0.0])


def test_a_robot_without_an_accelerometer_is_refused_at_the_first_update() -> None:
    estimator = StateEstimator.for_g1(JOINT_NAMES)
    state = RobotState(
        time=0.0, joint_pos=np.zeros(29), joint_vel=np.zeros(29), base_quat=np.array([1.0, 0, 0, 0]),
        base_ang_vel=np.zeros(3), base_pos=np.zeros(3), base_lin_vel=np.zeros(3), has_base_position=False,
    )  # fmt: skip
    with pytest.raises(ConfigError, match=r"needs the IMU's accelerometer \(RobotState.imu_accel\)"):
        estimator.update(state)


def test_missing_leg_joints_are_one_line() -> None:
    with pytest.raises(ConfigError, match="needs the leg joints left_hip_pitch_joint"):
        StateEstimator.for_g1(("waist_yaw_joint",))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("  accel: 0.5 ", "  accel: -0.5 "), r"estimator.yaml: process: accel: -0.5 is not allowed, it must be a number > 0$"),
        (("  foot_velocity: 0.05", "  foot_velocity: fast"), r"estimator.yaml: measurement.foot_velocity: expected a number, got 'fast'$"),
        (
            ("  hysteresis: 0.002", "  hysteresys: 0.002"),
            r"estimator.yaml: unknown key 'contact.hysteresys' \(valid keys: height_margin, hysteresis, settle_time\)$",
        ),
        (
            ("  settle_time: 0.015", "  settle_time: 0"),
            r"estimator.yaml: contact: settle_time: 0.0 is not allowed, it must be a number > 0$",
        ),
        (("  max_gap: 0.5", ""), r"estimator.yaml: missing required key 'fault.max_gap'$"),
    ],
)
def test_each_config_mistake_is_one_line(tmp_path: Path, edit: tuple[str, str], message: str) -> None:
    shipped = load_estimator_config()  # the shipped file loads
    assert shipped.process.accel > 0
    text = default_estimator_config_path().read_text()
    assert edit[0] in text
    path = tmp_path / "estimator.yaml"
    path.write_text(text.replace(edit[0], edit[1], 1))
    with pytest.raises(ConfigError, match=message) as error:
        load_estimator_config(path)
    assert "\n" not in str(error.value)


def test_a_nan_in_a_repeated_reading_latches_too(walk: tuple[tuple[str, ...], list[Row]]) -> None:
    """A reading with the previous one's time stamp carries nothing new to fuse, but its NaN is still a fault."""
    names, rows = walk
    estimator = StateEstimator.for_g1(names)
    for measured, _, _ in rows[:50]:
        estimator.update(measured)
    again = dataclasses.replace(rows[49][0], joint_vel=np.full(len(names), math.nan))
    estimator.update(again)
    assert estimator.fault == "non-finite input: joint_vel (legs)"


def test_the_estimate_carries_every_other_field_of_the_measured_state(walk: tuple[tuple[str, ...], list[Row]]) -> None:
    names, rows = walk
    estimator = StateEstimator.for_g1(names)
    measured = rows[10][0]
    estimate = estimator.update(measured)
    changed = {"base_pos", "base_lin_vel", "base_quat", "has_base_position"}
    for field in dataclasses.fields(RobotState):
        if field.name not in changed:
            assert getattr(estimate, field.name) is getattr(measured, field.name), field.name


FIRST_UPDATE = """
import time
import numpy as np
from controller.estimation.estimator import StateEstimator
from hw import g1
from hw.types import RobotState

estimator = StateEstimator.for_g1(g1.JOINT_NAMES)
assert not estimator.update_seconds
state = RobotState(
    time=0.0, joint_pos=np.array(g1.default_joint_vector()), joint_vel=np.zeros(g1.NUM_JOINTS), base_quat=np.array([1.0, 0, 0, 0]),
    base_ang_vel=np.zeros(3), base_pos=np.zeros(3), base_lin_vel=np.zeros(3), imu_accel=np.array([0.0, 0.0, 9.81]),
)
start = time.perf_counter()
estimate = estimator.update(state)
print(time.perf_counter() - start, estimate.base_pos[0], estimate.base_pos[1])
"""


@pytest.mark.slow
def test_the_first_update_in_a_fresh_process_costs_what_the_others_do() -> None:
    """The compiled update is loaded when the estimator is made (0.2-1 s here), not at the control loop's first tick."""
    out = subprocess.run([sys.executable, "-c", FIRST_UPDATE], capture_output=True, text=True, check=True, timeout=120).stdout.split()
    seconds, x, y = (float(v) for v in out)
    assert seconds < 0.1, seconds
    assert (x, y) == (0.0, 0.0)  # the estimate starts at the origin: loading left nothing behind
