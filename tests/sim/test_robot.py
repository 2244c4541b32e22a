"""Simulated robot: PD inside the physics step, effort limits, fall detection, interface lifecycle."""

from __future__ import annotations

import warnings

import mujoco
import numpy as np
import pytest

from hw import g1 as constants
from hw.types import JointCommand
from sim.robot import SimRobot


def test_pd_force_matches_law_and_is_clamped_to_effort_limit(g1_model) -> None:
    robot = SimRobot(g1_model)
    n = constants.NUM_JOINTS
    state = robot.read()
    kp, kd = np.full(n, 10.0), np.full(n, 1.0)
    target = state.joint_pos + 0.05
    robot.write(JointCommand(q=target, dq=np.zeros(n), kp=kp, kd=kd, tau_ff=np.zeros(n)))
    mujoco.mj_forward(robot.model, robot.data)
    expected = kp * (target - state.joint_pos) + kd * (0.0 - state.joint_vel)
    assert np.allclose(robot.data.actuator_force, expected, atol=1e-6)

    huge = JointCommand(q=state.joint_pos + 3.0, dq=np.zeros(n), kp=np.full(n, 1e4), kd=np.zeros(n), tau_ff=np.zeros(n))
    robot.write(huge)
    mujoco.mj_forward(robot.model, robot.data)
    limits = np.array([constants.EFFORT_LIMITS[j] for j in constants.JOINT_NAMES])
    assert np.allclose(np.abs(robot.data.actuator_force), limits)
    robot.close()


def test_damped_robot_falls_and_is_detected(g1_model) -> None:
    with SimRobot(g1_model) as robot:
        assert not robot.has_fallen()
        robot.damp()
        for _ in range(150):
            robot.step(10)
            if robot.has_fallen():
                break
        assert robot.has_fallen()
        t = robot.time
        robot.reset()
        assert not robot.has_fallen()
        assert robot.time == pytest.approx(t)  # reset keeps the clock running


def test_step_until_reaches_deadline(g1_model) -> None:
    with SimRobot(g1_model) as robot:
        robot.step_until(0.1)
        assert robot.time == pytest.approx(0.1)
        robot.step_until(0.05)  # in the past: no work
        assert robot.time == pytest.approx(0.1)


def test_close_twice_and_warns_when_never_closed(g1_model) -> None:
    robot = SimRobot(g1_model)
    robot.close()
    robot.close()
    leaked = SimRobot(g1_model)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        leaked.__del__()
    assert any(issubclass(w.category, ResourceWarning) for w in caught)
    leaked.close()
