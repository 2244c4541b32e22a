"""Joint maps that cannot work on the wire are refused at load, naming the file and the key."""

from __future__ import annotations

from pathlib import Path

import pytest

from hw import g1
from hw.errors import ConfigError
from hw.jointmap import load_hardware_config
from hw.shipped import config_dir

SIM_CAN = config_dir("hardware", "sim-can.yaml")
HIP_PITCH = "left_hip_pitch_joint: {bus: can0, protocol: mit, model: sim-leg-150, reply: cubemars, id: 1"


def _variant(tmp_path: Path, new: str) -> Path:
    text = SIM_CAN.read_text()
    assert HIP_PITCH in text
    path = tmp_path / "variant.yaml"
    path.write_text(text.replace(HIP_PITCH, new))
    return path


def test_damiao_replies_cannot_share_a_bus_with_other_variants(tmp_path: Path) -> None:
    path = _variant(tmp_path, HIP_PITCH.replace("reply: cubemars", "reply: damiao"))
    with pytest.raises(ConfigError, match="bus 'can0' mixes damiao replies with cubemars: their first bytes collide"):
        load_hardware_config(str(path))


@pytest.mark.parametrize("reply,motor_id,top", [("damiao", 16, 15), ("cubemars", 256, 255)])
def test_can_ids_must_fit_the_reply_byte(tmp_path: Path, reply: str, motor_id: int, top: int) -> None:
    path = _variant(tmp_path, HIP_PITCH.replace("reply: cubemars, id: 1", f"reply: {reply}, id: {motor_id}"))
    with pytest.raises(ConfigError, match=f"must be 1-{top} .*got {motor_id}"):
        load_hardware_config(str(path))


@pytest.mark.parametrize("name", ["sim-can", "sim-mixed"])
def test_g1_joints_take_the_joint_tables_limits_and_gains(name: str) -> None:
    cfg = load_hardware_config(name)
    for joint in g1.G1_JOINTS:
        got = cfg.joints[joint.name]
        stated = (got.position_limits, got.velocity_limit, got.torque_limit, got.kp, got.kd)
        assert stated == (joint.position_limits, joint.velocity_limit, joint.effort_limit, joint.kp, joint.kd), joint.name
    assert cfg.safety.damping_kd == g1.DAMPING_KD


def test_a_joint_may_narrow_a_limit_and_change_its_gains(tmp_path: Path) -> None:
    path = _variant(tmp_path, HIP_PITCH + ", position_limits: [-1.0, 1.5], velocity_limit: 10, torque_limit: 40.0, kp: 60, kd: 3")
    hip = load_hardware_config(str(path)).joints["left_hip_pitch_joint"]
    assert (hip.position_limits, hip.velocity_limit, hip.torque_limit, hip.kp, hip.kd) == ((-1.0, 1.5), 10.0, 40.0, 60.0, 3.0)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("position_limits: [-2.6, 2.0]", "position_limits [-2.6, 2.0] is wider than the G1's [-2.5307, 2.8798] (hw/g1.py, from the MJCF)"),
        ("position_limits: [-1.0, 2.88]", "position_limits [-1.0, 2.88] is wider than the G1's [-2.5307, 2.8798]"),
        ("torque_limit: 100", "torque_limit 100.0 is wider than the G1's 88.0 (hw/g1.py, the MJCF's actuatorfrcrange)"),
        ("velocity_limit: 31", "velocity_limit 31.0 is wider than the G1's 30.0 (hw/g1.py, COMMAND_VELOCITY_LIMIT)"),
    ],
)
def test_a_limit_wider_than_the_joint_tables_is_refused(tmp_path: Path, override: str, message: str) -> None:
    path = _variant(tmp_path, f"{HIP_PITCH}, {override}")
    with pytest.raises(ConfigError) as caught:
        load_hardware_config(str(path))
    line = str(caught.value)
    assert line.startswith(f"{path}: joints.left_hip_pitch_joint.") and message in line, line
    assert line.endswith("narrow it or remove it") and "\n" not in line


def test_a_joint_of_another_robot_must_state_its_torque_limit(tmp_path: Path) -> None:
    path = tmp_path / "arm.yaml"
    path.write_text(
        "buses: {can0: {kind: can, interface: virtual, channel: arm}}\n"
        "joints:\n  elbow: {bus: can0, protocol: mit, model: sim-arm-30, id: 1, position_limits: [-1, 1], velocity_limit: 10}\n"
    )
    with pytest.raises(ConfigError, match=r"missing required key 'joints.elbow.torque_limit'"):
        load_hardware_config(str(path), expected_joints=("elbow",))


def test_the_bus_rate_comes_from_the_config_and_simulated_buses_keep_to_the_physics(tmp_path: Path) -> None:
    assert load_hardware_config("sim-can").cycle_hz == g1.CONTROL_CYCLE_HZ  # left out: the G1's 500 Hz
    path = tmp_path / "rate.yaml"
    path.write_text(SIM_CAN.read_text() + "cycle_hz: 250\n")
    assert load_hardware_config(str(path)).cycle_hz == 250.0
    path.write_text(SIM_CAN.read_text() + "cycle_hz: 300\n")
    with pytest.raises(ConfigError, match=r"rate\.yaml: cycle_hz: simulated buses cycle in lockstep with the 500 Hz physics, .*got 300"):
        load_hardware_config(str(path))
    real = SIM_CAN.read_text().replace("simulated: true", "simulated: false")
    real = "\n".join(line for line in real.splitlines() if not line.startswith("imu_model:"))
    path.write_text(real + "\ncycle_hz: 300\n")  # a real robot's buses run at whatever rate they are given
    assert load_hardware_config(str(path)).cycle_hz == 300.0
    path.write_text(real + "\ncycle_hz: 0\n")
    with pytest.raises(ConfigError, match="cycle_hz must be positive, got 0"):
        load_hardware_config(str(path))
    path.write_text(real.replace("interface: virtual, channel: g1-can0", "interface: slcan, channel: /dev/ttyACM0").replace(
        "bitrate: 1000000}\n  can1", "bitrate: 300000}\n  can1", 1))  # fmt: skip
    with pytest.raises(ConfigError, match="slcan has no bitrate 300000: use one of 10000, "):
        load_hardware_config(str(path))
