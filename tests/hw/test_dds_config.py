"""DDS hardware configs: the shipped ones load, and each mistake is one line naming the file and the key."""

from __future__ import annotations

from pathlib import Path

import pytest

from hw import g1
from hw.dds.config import DdsHardwareConfig
from hw.errors import ConfigError
from hw.g1 import EFFORT_LIMITS, JOINT_NAMES
from hw.jointmap import load_hardware_config, load_robot_config
from hw.shipped import config_dir


def test_the_shipped_dds_configs_load_with_the_g1s_effort_limits() -> None:
    real, simulated = load_robot_config("g1-dds"), load_robot_config("sim-dds")
    assert isinstance(real, DdsHardwareConfig) and isinstance(simulated, DdsHardwareConfig)
    assert (real.dds.domain, real.dds.interface, real.simulated) == (0, "eth0", False)
    assert (simulated.dds.domain, simulated.dds.interface, simulated.simulated) == (1, "lo", True)
    assert tuple(real.joints) == JOINT_NAMES and all(real.joints[n].torque_limit == EFFORT_LIMITS[n] for n in JOINT_NAMES)
    assert real.dds.lowcmd_topic == "rt/lowcmd" and real.dds.lowstate_topic == "rt/lowstate"


def test_every_joint_takes_the_joint_table_unless_the_config_narrows_it(tmp_path: Path) -> None:
    for name in ("g1-dds", "sim-dds"):
        cfg = load_robot_config(name)
        assert isinstance(cfg, DdsHardwareConfig)
        for joint in g1.G1_JOINTS:
            got = cfg.joints[joint.name]
            assert (got.position_limits, got.velocity_limit, got.torque_limit) == (
                joint.position_limits,
                joint.velocity_limit,
                joint.effort_limit,
            )
            assert (got.kp, got.kd) == (joint.kp, joint.kd), joint.name
    text = (config_dir("hardware") / "sim-dds.yaml").read_text()
    path = tmp_path / "bench.yaml"
    path.write_text(text.replace("mode_pr: 0", "mode_pr: 0\njoints:\n  left_knee_joint: {position_limits: [0.0, 2.0], kp: 60}"))
    bench = load_robot_config(str(path))
    assert isinstance(bench, DdsHardwareConfig)
    knee = bench.joints["left_knee_joint"]
    assert (knee.position_limits, knee.kp, knee.kd, knee.torque_limit) == ((0.0, 2.0), 60.0, g1.G1_JOINT["left_knee_joint"].kd, 139.0)
    assert bench.joints["right_knee_joint"] == cfg.joints["right_knee_joint"] and tuple(bench.joints) == JOINT_NAMES


def test_a_bus_command_refuses_a_dds_config_in_one_line() -> None:
    with pytest.raises(ConfigError, match="'sim-dds' is a G1 over DDS: this command drives CAN/serial buses"):
        load_hardware_config("sim-dds")


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("mode_pr: 0", "mode_pr: 0\njoints: {left_knee_jointx: {kp: 60}}"), "unknown joints in the joint map: left_knee_jointx"),
        (
            ("mode_pr: 0", "mode_pr: 0\njoints: {left_knee_joint: {position_limits: [-0.1, 2.0]}}"),
            r"joints.left_knee_joint.position_limits \[-0.1, 2.0\] is wider than the G1's \[-0.087267, 2.8798\] \(hw/g1.py",
        ),
        (("dds: {domain: 1,", "dds: {domain: 300,"), "DDS domain must be 0..232, got 300"),
        (("mode_pr: 0", "mode_pr: 0\nbitrate: 1"), "bitrate"),
        (("state_timeout: 0.05", "state_timeout: 0"), "state_timeout"),
    ],
)
def test_mistakes_are_named(tmp_path: Path, edit: tuple[str, str], message: str) -> None:
    text = (config_dir("hardware") / "sim-dds.yaml").read_text()
    assert edit[0] in text
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace(edit[0], edit[1], 1))
    with pytest.raises(ConfigError, match=message) as caught:
        load_robot_config(str(path))
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)
