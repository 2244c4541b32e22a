"""Drills of the G1 over DDS against the simulated robot in its own process: each fault ends in damping with its cause named.

The robot process develops the fault mid-run (`g1ctl robot --dds --fault KIND@S`) or is killed;
the host's `DdsRobot` must latch ERROR with the cause, and the damping it sends must reach a
robot that still listens (the process counts damping commands). Nothing is lost from either
side's counters.
"""

from __future__ import annotations

import dataclasses
import re
import signal
import time
from collections.abc import Callable
from pathlib import Path

import pytest

pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")

from controller.runtime.dds_backend import RobotProcess
from hw.dds.config import DdsHardwareConfig
from hw.dds.robot import DdsRobot
from hw.jointmap import load_robot_config
from hw.robot import Lifecycle
from tests.conftest import HANG_S

pytestmark = pytest.mark.slow

FAULT_AT_S = 0.4  # after the robot's first command: the host is active by then


def _config(path: Path) -> DdsHardwareConfig:
    cfg = load_robot_config(str(path))
    assert isinstance(cfg, DdsHardwareConfig)
    return dataclasses.replace(cfg, safety=dataclasses.replace(cfg.safety, soft_start_time=0.2))  # the robot starts in the pose


def _cycle_until(robot: DdsRobot, state: Lifecycle) -> None:
    """Cycle at 500 Hz, as the controller does, until the robot reaches `state` (HANG_S bounds a hang)."""
    deadline = time.monotonic() + HANG_S
    while robot.state is not state and time.monotonic() < deadline:
        robot.cycle()
        if robot.cycles % 10 == 0:
            robot.read()  # as the controller does at 50 Hz: non-finite values are caught where the state is used
        time.sleep(0.002)


def _drive_until_error(robot: DdsRobot) -> None:
    """Configure, soft start and cycle until the robot latches ERROR, then a few cycles more."""
    robot.configure()
    robot.activate()
    _cycle_until(robot, Lifecycle.ERROR)
    for _ in range(20):  # damping keeps going out while latched
        robot.cycle()
        time.sleep(0.002)


@pytest.mark.parametrize(
    ("fault", "cause"),
    [
        ("stale", r"robot state stale: no good LowState_ within 50 ms"),
        ("bad-crc", r"LowState_s in a row with a bad CRC"),
        ("motor-error", r"left_knee_joint: motor error bits 0x00000020"),
        ("hot", r"left_knee_joint: over-temperature 95 C \(limit 85 C\)"),
        ("nan", r"non-finite values in the robot's state \(left_knee_joint\)"),
        ("mode-machine", r"the robot's mode_machine changed from 5 to 6"),
    ],
)
def test_a_fault_of_the_robot_ends_in_damping_with_its_cause(fault: str, cause: str, sim_dds_config: Callable[[], Path]) -> None:
    cfg = _config(sim_dds_config())  # a domain per drill
    process = RobotProcess(cfg, extra_args=("--gantry", "--fault", f"{fault}@{FAULT_AT_S}"), truth=False)
    try:
        with DdsRobot(cfg) as robot:
            _drive_until_error(robot)
            assert robot.state is Lifecycle.ERROR and robot.fault_count == 1
            assert any(re.search(cause, f) for f in robot.faults), robot.faults
            counters = robot.counters()
            # The fault strikes 0.4 s in (200 cycles at 500 Hz; 59 good states with two test runs at once): the host and
            # the robot exchanged for longer than the 50 ms watchdog (25 cycles) first.
            assert counters.commands_sent > 25 and counters.states_received > 25
    finally:
        report = process.stop()
    assert report["exit_code"] == 0 and report["faults"] == [fault]
    assert report["commands"] > 25  # what the host sent was taken up to the fault (nothing lost from the report)
    assert report["damping_commands"] >= 3  # and the damping after it reached the robot, even with its new mode_machine


def test_the_robot_process_killed_mid_run_ends_in_damping(sim_dds_config: Callable[[], Path]) -> None:
    cfg = _config(sim_dds_config())
    process = RobotProcess(cfg, extra_args=("--gantry",), truth=False)
    try:
        with DdsRobot(cfg) as robot:
            robot.configure()
            robot.activate()
            _cycle_until(robot, Lifecycle.ACTIVE)
            assert robot.state is Lifecycle.ACTIVE
            process.process.send_signal(signal.SIGKILL)
            _cycle_until(robot, Lifecycle.ERROR)
            assert robot.state is Lifecycle.ERROR, "no fault after the robot process died"
            assert robot.faults[0].startswith("robot state stale")  # the 50 ms watchdog
    finally:
        report = process.stop()
    assert report["exit_code"] == -signal.SIGKILL
