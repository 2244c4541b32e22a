"""The emulated G1 low-level controller: commands applied, bad ones refused with the robot going limp, states reported."""

from __future__ import annotations

import numpy as np
import pytest

from hw import g1
from hw.emulation.g1_lowlevel import G1LowLevel, LowLevelConfig, roll_pitch_yaw
from hw.emulation.plant import StaticPlant
from hw.protocols import unitree_hg as hg


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def rig() -> tuple[G1LowLevel, StaticPlant, Clock]:
    clock = Clock()
    plant = StaticPlant({name: 0.01 * i for i, name in enumerate(g1.JOINT_NAMES)}, clock=clock)
    return G1LowLevel(plant, LowLevelConfig(mode_machine=5, command_timeout_s=0.1)), plant, clock


def command(mode_machine: int = 5, kp: float = 40.0) -> np.ndarray:
    record = hg.new_low_cmd(mode_machine=mode_machine)
    for i in range(29):
        slot = record["motor_cmd"][i]
        slot["mode"], slot["q"], slot["kp"], slot["kd"] = 1, 0.1 * i, kp, 1.0
    return hg.with_crc(record)


def gains(plant: StaticPlant) -> set[tuple[float, float]]:
    return {(kp, kd) for (_, _, kp, kd, _) in plant.commands.values()}


def test_a_valid_command_puts_its_pd_laws_on_the_joints() -> None:
    robot, plant, clock = rig()
    robot.tick(0.0)
    assert robot.limp and gains(plant) == {(0.0, 0.0)}  # limp until the first command
    robot.receive(command(), clock.t)
    robot.tick(clock.t)
    knee = g1.JOINT_NAMES.index("left_knee_joint")
    assert not robot.limp and plant.commands["left_knee_joint"] == pytest.approx((0.1 * knee, 0.0, 40.0, 1.0, 0.0))
    assert robot.counters.commands == 1


@pytest.mark.parametrize(
    ("bad", "counter", "reason"),
    [("crc", "crc_errors", "bad CRC"), ("mode_machine", "mode_machine_mismatches", "mode_machine 9 (this robot is 5)")],
)
def test_a_bad_command_is_refused_and_the_robot_goes_limp(bad: str, counter: str, reason: str) -> None:
    robot, plant, _ = rig()
    robot.receive(command(), 0.0)
    wrong = command(mode_machine=9) if bad == "mode_machine" else command()
    if bad == "crc":
        wrong["motor_cmd"][0]["kp"] = 500.0  # changed after the CRC was set
    robot.receive(wrong, 0.01)
    robot.tick(0.01)
    assert robot.limp and reason in (robot.limp_reason or "") and getattr(robot.counters, counter) == 1
    assert gains(plant) == {(0.0, 0.0)}
    robot.receive(command(), 0.02)  # a good one brings it back
    robot.tick(0.02)
    assert not robot.limp and gains(plant) == {(40.0, 1.0)}


def test_a_command_gap_past_the_timeout_makes_it_limp() -> None:
    robot, plant, _ = rig()
    robot.receive(command(), 0.0)
    robot.tick(0.05)
    assert not robot.limp
    robot.tick(0.15)
    robot.tick(0.16)
    assert robot.limp and robot.counters.timeouts == 1 and "no LowCmd_ for 0.150 s" in (robot.limp_reason or "")
    assert gains(plant) == {(0.0, 0.0)}


def test_the_low_state_reports_the_plant_with_its_crc() -> None:
    robot, _, clock = rig()
    robot.receive(command(), 0.0)
    clock.t = 1.234
    remote = hg.encode_wireless_remote(hg.WirelessRemote(ly=1.0, buttons=frozenset({"start"})))
    state = robot.low_state(remote)
    assert hg.crc_ok(state) and int(state["mode_machine"]) == 5 and int(state["tick"]) == 1234
    fields = hg.low_state_fields(hg.unpack_low_state(hg.pack(state)))
    assert fields["joints"][3]["q"] == pytest.approx(0.03) and fields["joints"][3]["vol"] == pytest.approx(50.4)
    assert fields["imu"]["quaternion"] == [1.0, 0.0, 0.0, 0.0] and fields["imu"]["rpy"] == [0.0, 0.0, 0.0]
    assert fields["wireless_remote"]["ly"] == 1.0 and fields["wireless_remote"]["buttons"] == ["start"]
    assert roll_pitch_yaw((np.cos(0.25), 0.0, 0.0, np.sin(0.25))) == pytest.approx((0.0, 0.0, 0.5))
