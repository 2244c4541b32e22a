"""The bench interface (`open_robot`, `hw.bench.BenchRobot`) on simulated buses in this process, on the simulated G1
in its own robot process, and on a real-bus config where nothing answers or a bus does not open."""

from __future__ import annotations

import itertools
import json
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from controller.runtime.bench_robot import open_robot
from hw.errors import BusError, ConfigError, LifecycleError, MotorNotFoundError, NotConfirmed
from hw.g1 import JOINT_NAMES
from hw.robot import Lifecycle
from tests.conftest import a_robot_config, sim_can_on_real_buses


def one_line(exc: pytest.ExceptionInfo[BaseException]) -> str:
    message = str(exc.value)
    assert "\n" not in message, message
    return message


@pytest.mark.slow
@pytest.mark.parametrize("interruption", [RuntimeError, KeyboardInterrupt])
def test_the_robot_ends_damped_whatever_ends_the_script(interruption: type[BaseException]) -> None:
    with pytest.raises(interruption), open_robot("sim-can") as robot:
        move = robot.move("left_elbow_joint", 1.0, speed=1.0)
        assert move.reached and move.position == pytest.approx(1.0, abs=0.05), move
        assert robot.state is Lifecycle.ACTIVE  # holding the elbow when the script fails
        raise interruption("the script failed")
    assert robot.state is Lifecycle.CLOSED
    wire = robot.wire_report  # what the emulated motors took, judged by their own firmware
    assert wire is not None and wire["safe_since"] is not None and wire["outside_limits"] == 0, wire
    assert wire["commands"] > 29 * 100


@pytest.mark.slow
def test_a_move_outside_the_limits_is_refused_and_nothing_is_sent() -> None:
    with open_robot("sim-can") as robot:
        with pytest.raises(ConfigError) as refused:
            robot.move("left_knee_joint", 3.2)
        assert one_line(refused) == (
            "move left_knee_joint to 3.2 rad refused: outside its limits [-0.0873, +2.8798] rad (hardware config 'sim-can'); "
            "nothing was sent"
        )
        with pytest.raises(ConfigError, match="outside its limits"):
            robot.move("left_knee_joint", float("nan"))
        assert robot.state is Lifecycle.INACTIVE  # never activated: the motors stayed limp
        with pytest.raises(ConfigError, match="unknown joint 'left_knee'"):
            robot.move("left_knee", 0.5)
        with pytest.raises(ConfigError, match=r"speed must be within \(0, 2.0\] rad/s, got 5"):
            robot.move("left_knee_joint", 0.5, speed=5)
        moved = robot.move("left_knee_joint", 1.2, speed=1.0)  # within them: reached, and held
        assert moved.reached and robot.read().joint_pos[JOINT_NAMES.index("left_knee_joint")] == pytest.approx(1.2, abs=0.05)


@pytest.mark.slow
def test_a_zero_needs_its_confirmation_and_idle_joints() -> None:
    knee = JOINT_NAMES.index("left_knee_joint")
    with open_robot("sim-can") as robot:
        before = robot.read().joint_pos[knee]
        assert before == pytest.approx(0.669, abs=0.05)  # the default pose, on the gantry
        asked: list[str] = []

        def decline(question: str) -> bool:
            asked.append(question)
            return False

        with pytest.raises(NotConfirmed) as declined:
            robot.zero("left_knee_joint", confirm=decline)
        assert one_line(declined).endswith("not confirmed; nothing was sent")
        assert asked == [f"set the zero of left_knee_joint at its current position ({before:+.4f} rad) on 'sim-can'?"]
        assert robot.read().joint_pos[knee] == pytest.approx(before, abs=0.01)
        robot.move("left_elbow_joint", 0.8, speed=1.0)
        with pytest.raises(LifecycleError, match="the robot is holding its joints; damp"):
            robot.zero("left_knee_joint", confirm=True)
        robot.damp(0.05)
        assert robot.zero("left_knee_joint", confirm=lambda question: True).action == "encoder zero set on the motor"
        assert robot.read().joint_pos[knee] == pytest.approx(0.0, abs=0.01)  # the motor counts from here now
        with pytest.raises(Exception, match=r"the robot is damped \(damping requested on the bench\): rearm\(\)"):
            robot.move("left_elbow_joint", 0.5)
        robot.rearm()
        assert robot.move("left_elbow_joint", 0.5, speed=1.0).reached


@pytest.mark.slow
def test_the_imu_summary_and_samples_on_rs485_and_can() -> None:
    with open_robot("sim-mixed") as robot:
        assert robot.transport == "buses" and {r.bus for r in robot.scan()} >= {"rs485_left", "can1"}
        summary = robot.imu(0.3)
        assert summary.samples >= 140 and summary.frames >= summary.samples and summary.crc_errors == 0 and summary.sequence_gaps == 0
        assert summary.rate_hz == pytest.approx(500, rel=0.1)
        assert summary.accel_mean[2] == pytest.approx(9.81, abs=0.05) and max(map(abs, summary.gyro_mean)) < 0.01
        samples = robot.imu_samples(0.1)
        assert len(samples) >= 45 and all(b.time > a.time for a, b in itertools.pairwise(samples))
        assert samples[0].gravity() == pytest.approx((0.0, 0.0, 9.81), abs=0.01)  # upright on the gantry


@pytest.mark.slow
def test_the_g1_over_dds_in_its_robot_process() -> None:
    pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")
    with open_robot("sim-dds") as robot:
        assert robot.transport == "dds"
        rows = robot.scan()
        assert [r.joint for r in rows] == list(JOINT_NAMES) and all(r.healthy and r.error == "0x00000000" for r in rows)
        assert "'ai' active" in robot.notes()[0]  # only listened: the robot's own controller still holds it
        with pytest.raises(ConfigError) as refused:
            robot.zero("left_knee_joint", confirm=True)
        assert "zero has no meaning on a G1 over DDS ('sim-dds')" in one_line(refused)
        assert robot.imu(0.2).samples > 50
        move = robot.move("left_elbow_joint", 1.0, speed=1.0)  # releases the motion service first
        assert move.reached, move
        assert "none active" in robot.notes()[0]
        with pytest.raises(ConfigError, match="outside its limits"):
            robot.move("left_elbow_joint", 2.5)
    assert robot.state is Lifecycle.CLOSED
    wire = robot.wire_report  # the robot process's own audit of every LowCmd_ it took
    assert wire is not None and wire["safe_since"] is not None and wire["outside_limits"] == 0, wire


@pytest.mark.slow
def test_a_real_g1_is_opened_listening_and_released_at_the_first_command(tmp_path: Path, claim_dds_domain: Callable[[], int]) -> None:
    """A real robot's config (a copy of g1-dds.yaml on loopback) and a stand-in G1 started by hand on its gantry."""
    pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")
    domain = claim_dds_domain()
    config = a_robot_config(tmp_path, domain)
    # The stand-in is a Python process stepping MuJoCo: on a loaded machine its states pause longer than a real G1's,
    # and it is started together with the bring-up, loading MuJoCo first, where a real G1 is up before anyone connects.
    text = config.read_text().replace("state_timeout: 0.05", "state_timeout: 0.25")
    config.write_text(text.replace("connect_timeout: 2.0", "connect_timeout: 30.0"))
    assert "connect_timeout: 30.0" in config.read_text()
    command = [sys.executable, "-m", "controller.cli", "robot", "--dds", "--gantry", "--domain", str(domain), "--duration", "60"]
    stand_in = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        with open_robot(str(config)) as robot:
            assert all(r.healthy for r in robot.scan()) and "'ai' active" in robot.notes()[0]  # listening only
            sweep = robot.sweep("left_elbow_joint", fraction=0.1, speed=1.0)
            assert sweep.reached_range(), sweep
            assert "none active" in robot.notes()[0]  # released for the sweep
        assert robot.state is Lifecycle.CLOSED and robot.wire_report is None  # a real robot: no emulator audits it
    finally:
        stand_in.send_signal(signal.SIGTERM)
        out, err = stand_in.communicate(timeout=20)
    counters = json.loads(out.strip().splitlines()[-1])
    assert stand_in.returncode == 0, err
    assert counters["motion_release_requests"] == 1 and counters["damping_commands"] >= 1  # ended damped


def test_a_bus_that_cannot_be_opened_is_refused_in_one_line(tmp_path: Path) -> None:
    config = sim_can_on_real_buses(tmp_path, can0="{kind: can, interface: socketcan, channel: g1-missing0, bitrate: 1000000}")
    with pytest.raises(BusError) as refused, open_robot(str(config)):
        pass
    assert one_line(refused).startswith("cannot open CAN bus 'can0' (socketcan:g1-missing0): ")


def test_silent_motors_are_scanned_and_refuse_a_move(tmp_path: Path) -> None:
    with open_robot(str(sim_can_on_real_buses(tmp_path))) as robot:
        rows = robot.scan()
        assert not any(r.answered or r.healthy for r in rows) and rows[0].error == "no reply"
        with pytest.raises(MotorNotFoundError) as refused:
            robot.sweep("left_knee_joint")
        assert one_line(refused).startswith("motors did not answer: left_hip_pitch_joint (bus can0, id 1), ")
        assert robot.state is Lifecycle.INACTIVE
        with pytest.raises(ConfigError, match="has no IMU"):
            robot.imu(0.1)


def test_an_unknown_config_is_one_line() -> None:
    with pytest.raises(ConfigError, match="unknown hardware config 'moon-robot'"), open_robot("moon-robot"):
        pass
