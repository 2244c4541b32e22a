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


def test_g1_joints_without_a_torque_limit_take_the_g1_effort_limit(tmp_path: Path) -> None:
    cfg = load_hardware_config(str(SIM_CAN))
    assert {name: joint.torque_limit for name, joint in cfg.joints.items()} == g1.EFFORT_LIMITS
    assert cfg.safety.damping_kd == g1.DAMPING_KD
    path = _variant(tmp_path, HIP_PITCH + ", torque_limit: 40.0")
    assert load_hardware_config(str(path)).joints["left_hip_pitch_joint"].torque_limit == 40.0  # a config's own limit wins


def test_a_joint_of_another_robot_must_state_its_torque_limit(tmp_path: Path) -> None:
    path = tmp_path / "arm.yaml"
    path.write_text(
        "buses: {can0: {kind: can, interface: virtual, channel: arm}}\n"
        "joints:\n  elbow: {bus: can0, protocol: mit, model: sim-arm-30, id: 1, position_limits: [-1, 1], velocity_limit: 10}\n"
    )
    with pytest.raises(ConfigError, match=r"missing required key 'joints.elbow.torque_limit'"):
        load_hardware_config(str(path), expected_joints=("elbow",))
