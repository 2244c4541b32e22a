"""Hardware configs of a G1 over its low-level DDS topics: `configs/hardware/g1-dds.yaml`, `sim-dds.yaml`.

A DDS config (`transport: dds`) names the domain, the network interface and the topics, and
the safety thresholds; there are no buses or motor ids: the robot's main board addresses the
motors. Each joint's limits and bring-up gains are the G1 joint table's (`hw.g1.G1_JOINTS`):
`joints` may narrow a limit or change a gain of a joint, and a wider limit is refused.
`simulated: true` marks a config whose robot `g1ctl` starts itself (`g1ctl robot --dds` in a
child process). Pure configuration: importing this needs no cyclonedds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from hw.dds.session import DdsConfig
from hw.emulation.imu_model import ImuModelConfig
from hw.errors import ConfigError
from hw.g1 import DAMPING_KD, JOINT_NAMES
from hw.joint_overrides import check_within_g1_limits, with_g1_joint_table
from hw.yamlconfig import check_position_limits, from_dict


@dataclass(frozen=True)
class DdsJointConfig:
    position_limits: tuple[float, float]  # rad
    velocity_limit: float  # rad/s
    torque_limit: float  # N m
    # Left out of the YAML, each of these is the G1 joint table's (hw.g1.G1_JOINTS).
    kp: float = 20.0  # bring-up gains (soft start, sweep)
    kd: float = 1.0

    def __post_init__(self) -> None:
        check_position_limits(self.position_limits)
        if self.velocity_limit <= 0 or self.torque_limit <= 0 or self.kp < 0 or self.kd < 0:
            raise ValueError("velocity_limit and torque_limit must be positive, kp and kd not negative")


@dataclass(frozen=True)
class DdsSafetyConfig:
    state_timeout: float = 0.05  # s: the newest good LowState_ older than this is a fault (robot gone, cable out)
    max_position_step: float = 0.3  # rad: largest change of a position target between cycles
    max_temperature: float = 85.0  # deg C, the hotter of a motor's two sensors
    damping_kd: float = DAMPING_KD  # N m s/rad while damping
    soft_start_time: float = 3.0  # s: ramp to the default pose on activate
    max_bad_states: int = 5  # LowState_s in a row with a bad CRC before it is a fault

    def __post_init__(self) -> None:
        if self.state_timeout <= 0 or self.soft_start_time < 0 or self.max_position_step <= 0 or self.max_bad_states < 1:
            raise ValueError("state_timeout and max_position_step must be positive, soft_start_time not negative, max_bad_states >= 1")


@dataclass(frozen=True)
class DdsHardwareConfig:
    transport: Literal["dds"]
    dds: DdsConfig
    joints: dict[str, DdsJointConfig]
    description: str = ""
    simulated: bool = False  # true: g1ctl starts the simulated G1 (`g1ctl robot --dds`) on this domain and interface
    mode_pr: int = 0  # 0: the ankles and waist in pitch/roll mode
    connect_timeout: float = 2.0  # s to wait for the robot's first LowState_
    release_motion_service: bool = True  # ask the robot's high-level motion service to let go before low-level control
    imu_model: ImuModelConfig | None = None  # simulated only: the simulated G1's IMU noise and bias (None: the model's defaults)
    safety: DdsSafetyConfig = field(default_factory=DdsSafetyConfig)


def is_dds_config(data: Any) -> bool:
    return isinstance(data, dict) and data.get("transport") == "dds"


def dds_config_from(data: Any, source: str, expected_joints: tuple[str, ...] = JOINT_NAMES) -> DdsHardwareConfig:
    """Build and check a DDS hardware config from its parsed YAML (the joint names first: a misspelt one is named as such)."""
    joints = data.get("joints") if isinstance(data, dict) else None
    unknown = [j for j in joints if j not in expected_joints] if isinstance(joints, dict) else []
    if unknown:
        raise ConfigError(f"{source}: unknown joints in the joint map: {', '.join(unknown)}")
    data = with_g1_joint_table(data, every_joint=expected_joints)
    joints = data.get("joints") if isinstance(data, dict) else None
    missing = [j for j in expected_joints if j not in joints] if isinstance(joints, dict) else []
    if missing:  # joints of another robot, which the G1 joint table does not hold
        raise ConfigError(f"{source}: joints missing from the joint map: {', '.join(missing)}")
    cfg = from_dict(DdsHardwareConfig, data, source)
    check_within_g1_limits(cfg.joints, source)
    check_imu_model(cfg.imu_model, cfg.simulated, source)
    return cfg


def check_imu_model(model: ImuModelConfig | None, simulated: bool, source: str) -> None:
    """An IMU error model belongs to a simulated robot: a real IMU brings its own noise (both config kinds check it alike)."""
    if model is not None and not simulated:
        raise ConfigError(
            f"{source}: imu_model: only a simulated robot's IMU is modelled ('simulated: true'); a real robot's IMU measures "
            "with its own noise: remove the block"
        )
