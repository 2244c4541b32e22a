"""`g1ctl robot --dds` in its own process: valid LowState_ on loopback DDS, a bad LowCmd_ refused, every one until "ai" is released."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from collections.abc import Callable

import numpy as np
import pytest

pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")

from hw.dds import messages as m
from hw.dds.link import DdsLink, RobotNotFoundError
from hw.dds.motion_switcher import release_motion_service
from hw.dds.session import DdsConfig, DdsSession
from hw.emulation.g1_faults import IMU_BIAS_DRILL
from hw.protocols import unitree_hg as hg
from tests.conftest import HANG_S, wait_for

pytestmark = pytest.mark.slow


def test_the_simulated_robot_publishes_low_state_and_refuses_a_bad_command(claim_dds_domain: Callable[[], int]) -> None:
    domain = claim_dds_domain()
    child = subprocess.Popen(
        [sys.executable, "-m", "controller.cli", "robot", "--dds", "--domain", str(domain), "--duration", "6", "--motion-mode", ""],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    session = DdsSession(DdsConfig(domain=domain, interface="lo"))
    try:
        states = session.reader("rt/lowstate", m.LowState_)
        commands = session.writer("rt/lowcmd", m.LowCmd_)
        received: list[np.ndarray] = []

        def states_arrive(count: int) -> bool:
            """Take what arrived until `count` more states came: the robot ran at least that many cycles meanwhile."""
            goal = len(received) + count

            def taken() -> bool:
                received.extend(m.low_state_to_record(s) for s in states.take(N=10) if isinstance(s, m.LowState_))
                return len(received) >= goal

            return wait_for(taken)

        assert states_arrive(20), f"{len(received)} LowState_ in {HANG_S} s"
        assert all(hg.crc_ok(r) and int(r["mode_machine"]) == 5 for r in received)
        ticks = [int(r["tick"]) for r in received]
        assert ticks == sorted(ticks) and ticks[-1] > ticks[0]
        good = hg.new_low_cmd(mode_machine=5)
        good["motor_cmd"]["mode"][:29], good["motor_cmd"]["kp"][:29], good["motor_cmd"]["kd"][:29] = 1, 20.0, 1.0
        good = hg.with_crc(good)
        bad = good.copy()
        bad["crc"] ^= 1
        commands.write(m.low_cmd_from_record(bad))
        assert states_arrive(25)  # keep-last-1: the robot takes the newest command, so the bad one must stand alone for some cycles
        for _ in range(20):  # good commands, one a cycle
            commands.write(m.low_cmd_from_record(good))
            assert states_arrive(1)
    finally:
        session.close()
    out, err = child.communicate(timeout=20)
    assert child.returncode == 0, err
    report = json.loads(out.strip().splitlines()[-1])
    assert report["states_published"] > 1000 and report["crc_errors"] >= 1 and report["commands"] >= 1
    assert report["timeouts"] >= 1 and report["limp"]  # the commands stopped: limp again, as the robot would


def test_the_host_link_connects_releases_the_motion_service_and_holds_a_joint(claim_dds_domain: Callable[[], int]) -> None:
    domain = claim_dds_domain()
    lonely = DdsLink(DdsConfig(domain=claim_dds_domain(), interface="lo"))
    try:
        with pytest.raises(RobotNotFoundError, match=r"no LowState_ from the robot on DDS domain \d+, interface 'lo' in 0.3 s"):
            lonely.connect(timeout_s=0.3)
    finally:
        lonely.close()
    child = subprocess.Popen(
        [sys.executable, "-m", "controller.cli", "robot", "--dds", "--domain", str(domain), "--duration", "60", "--mode-machine", "7"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    link = DdsLink(DdsConfig(domain=domain, interface="lo"))
    try:
        first = link.connect(timeout_s=HANG_S)  # the robot process starts meanwhile
        assert link.mode_machine == 7 and hg.crc_ok(first)
        command = hg.new_low_cmd()  # mode_machine is the link's to set
        knee = 3  # left_knee_joint
        command["motor_cmd"]["mode"][knee], command["motor_cmd"]["q"][knee] = 1, 0.6
        command["motor_cmd"]["kp"][knee], command["motor_cmd"]["kd"][knee] = 60.0, 2.0

        def send_until_states_arrive(count: int) -> bool:
            """Send the command and take the states until `count` more came: the robot ran at least that many cycles meanwhile."""
            goal = link.counters.states_received + count

            def sent_and_taken() -> bool:
                link.send(command)
                link.poll()
                return link.counters.states_received >= goal

            return wait_for(sent_and_taken)

        assert send_until_states_arrive(10)  # the robot's "ai" mode owns the motors: refused
        assert release_motion_service(link.session, wait_s=0.05) == "ai"
        assert send_until_states_arrive(300)
        assert link.state is not None and int(link.state["motor_state"]["mode"][knee]) == 1
        assert link.counters.crc_errors == 0 and link.counters.states_received > 100
    finally:
        link.close()
        child.send_signal(signal.SIGTERM)
    out, err = child.communicate(timeout=20)
    assert child.returncode == 0, err
    report = json.loads(out.strip().splitlines()[-1])
    assert report["commands"] > 100 and report["mode_machine_mismatches"] == 0 and report["crc_errors"] == 0
    assert report["commands_while_high_level"] >= 1 and report["motion_mode"] == "" and report["motion_release_requests"] == 1


def test_the_simulated_robots_imu_is_noisy_about_gravity_and_takes_its_bias_fault(claim_dds_domain: Callable[[], int]) -> None:
    """On the gantry (still): LowState_'s accelerometer reads +9.81 up with sim-dds's imu_model noise; 0.3 s after the first
    command, the `imu-bias` fault's bias on the gyro and the accelerometer."""
    domain = claim_dds_domain()
    child = subprocess.Popen(
        [sys.executable, "-m", "controller.cli", "robot", "--dds", "--domain", str(domain), "--duration", "8", "--motion-mode", "",
         "--gantry", "--joint-map", "sim-dds", "--seed", "3", "--fault", "imu-bias@0.3"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    session = DdsSession(DdsConfig(domain=domain, interface="lo"))
    try:
        states = session.reader("rt/lowstate", m.LowState_)
        commands = session.writer("rt/lowcmd", m.LowCmd_)
        received: list[np.ndarray] = []

        def take(count: int) -> np.ndarray:
            """The IMU of `count` states to come (the newest at each look): gyroscope (columns 0-2) and accelerometer (3-5)."""
            received.clear()

            def taken() -> bool:
                received.extend(m.low_state_to_record(s) for s in states.take(N=10) if isinstance(s, m.LowState_))
                return len(received) >= count

            assert wait_for(taken, timeout=3 * HANG_S), f"{len(received)} LowState_ in {3 * HANG_S} s"
            return np.array([[*r["imu_state"]["gyroscope"], *r["imu_state"]["accelerometer"]] for r in received])

        still = take(150)
        assert still[:, 3:].mean(axis=0) == pytest.approx((0.0, 0.0, 9.81), abs=0.01)
        assert still[:, 3:].std(axis=0) == pytest.approx(0.0271, rel=0.2) and still[:, :3].std(axis=0) == pytest.approx(0.00386, rel=0.2)
        command = hg.new_low_cmd(mode_machine=5)
        command["motor_cmd"]["mode"][:29], command["motor_cmd"]["kd"][:29] = 1, 1.0
        commands.write(m.low_cmd_from_record(hg.with_crc(command)))  # the fault's clock starts with the first command taken
        time.sleep(0.6)  # the bias strikes 0.3 s after the command, on the robot's wall clock
        biased = take(150)
        assert biased[:, :3].mean(axis=0) == pytest.approx(IMU_BIAS_DRILL.gyro, abs=0.002)
        assert biased[:, 3:].mean(axis=0) == pytest.approx(np.add((0.0, 0.0, 9.81), IMU_BIAS_DRILL.accel), abs=0.01)
    finally:
        session.close()
        child.send_signal(signal.SIGTERM)
    out, err = child.communicate(timeout=20)
    assert child.returncode == 0, err
    assert json.loads(out.strip().splitlines()[-1])["faults"] == ["imu-bias"]
