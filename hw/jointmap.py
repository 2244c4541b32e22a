"""Hardware configs: buses, the joint map (joint -> bus, protocol, motor), IMU and safety limits.

`load_hardware_config` validates everything a bring-up engineer can get wrong in the
YAML: unknown keys, missing or unknown joints, duplicate motor ids on one bus, a bus that
is not declared, a motor model without ranges, limits in the wrong order. A G1 joint's
limits and bring-up gains are the G1 joint table's (`hw.g1.G1_JOINTS`) unless the YAML
narrows them; a wider limit is refused (`hw.joint_overrides`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from hw.dds.config import DdsHardwareConfig, check_imu_model, dds_config_from, is_dds_config
from hw.emulation.imu_model import ImuModelConfig
from hw.errors import ConfigError
from hw.g1 import CONTROL_CYCLE_HZ, DAMPING_KD, JOINT_NAMES
from hw.joint_overrides import check_within_g1_limits, with_g1_joint_table
from hw.protocols import slcan
from hw.protocols.mit import MitRanges
from hw.shipped import config_dir
from hw.yamlconfig import check_position_limits, from_dict, load_yaml, preset_names, resolve_preset


@dataclass(frozen=True)
class BusConfig:
    """A CAN bus (python-can interface + channel) or a serial port (device path or pyserial URL)."""

    kind: Literal["can", "serial"]
    interface: str = ""  # can: socketcan, pcan, slcan, virtual, ...
    channel: str = ""  # can: can0, PCAN_USBBUS1, ...
    bitrate: int = 1_000_000
    port: str = ""  # serial: /dev/ttyUSB0, loop://, ...
    baudrate: int = 4_000_000  # serial, and the serial link of an slcan adapter
    rs485: bool = False  # serial: drive RTS for the transceiver direction (kernel RS-485 mode)
    open_delay: float = 0.0  # can over slcan: seconds to wait after opening the adapter's port (an Arduino-based one resets)

    def __post_init__(self) -> None:
        if self.kind == "can" and not (self.interface and self.channel):
            raise ValueError("a can bus needs 'interface' and 'channel'")
        if self.kind == "serial" and not self.port:
            raise ValueError("a serial bus needs 'port'")
        if self.kind == "can" and self.interface == "slcan" and self.bitrate not in slcan.BITRATE_COMMANDS:
            raise ValueError(f"slcan has no bitrate {self.bitrate}: use one of {', '.join(map(str, slcan.BITRATE_COMMANDS))}")


@dataclass(frozen=True)
class JointConfig:
    bus: str
    protocol: Literal["mit", "unitree-rs485"]
    id: int
    position_limits: tuple[float, float]
    velocity_limit: float
    torque_limit: float  # N m, joint side
    # A G1 joint leaves out what the G1 joint table holds: position, velocity and torque limits, kp, kd.
    model: str = ""  # mit: a model in configs/motors.yaml
    reply: Literal["basic", "cubemars", "damiao"] = "cubemars"  # mit reply variant
    direction: int = 1  # +1 or -1: motor positive direction relative to the joint
    zero_offset: float = 0.0  # joint angle (rad) when the motor reads zero
    gear_ratio: float = 1.0  # rotor turns per joint turn (the motor reports rotor-side values)
    kp: float = 20.0  # bring-up gains (soft start, sweep)
    kd: float = 1.0

    def __post_init__(self) -> None:
        check_position_limits(self.position_limits)
        if self.direction not in (1, -1):
            raise ValueError(f"direction must be 1 or -1, got {self.direction}")
        if self.gear_ratio <= 0 or self.velocity_limit <= 0 or self.torque_limit <= 0:
            raise ValueError("gear_ratio, velocity_limit and torque_limit must be positive")
        if self.protocol == "mit" and not self.model:
            raise ValueError("a mit joint needs 'model'")
        if self.protocol == "unitree-rs485" and not 0 <= self.id <= 14:
            raise ValueError(f"an RS-485 motor id must be 0-14 (15 is broadcast), got {self.id}")
        if self.protocol == "mit":
            # The reply names its motor in byte 0: the whole byte, or its low nibble for Damiao.
            top = 15 if self.reply == "damiao" else 255
            if not 1 <= self.id <= top:
                raise ValueError(
                    f"a CAN motor id with {self.reply} replies must be 1-{top} (the reply carries it in byte 0), got {self.id}"
                )


def motor_to_joint(j: JointConfig, position: float, velocity: float, torque: float) -> tuple[float, float, float]:
    """Motor-side reading -> joint side: q = s q_m / g + offset, dq = s dq_m / g, tau = s tau_m g
    (s: direction, g: gear ratio). Gains go the other way as kp_m = kp / g^2, kd_m = kd / g^2."""
    g, s = j.gear_ratio, j.direction
    return s * position / g + j.zero_offset, s * velocity / g, s * torque * g


def joint_to_motor(j: JointConfig, q: float, dq: float, tau: float) -> tuple[float, float, float]:
    """Joint side -> motor side, the inverse of `motor_to_joint`: q_m = s (q - offset) g, dq_m = s dq g, tau_m = s tau / g."""
    g, s = j.gear_ratio, j.direction
    return s * (q - j.zero_offset) * g, s * dq * g, s * tau / g


@dataclass(frozen=True)
class ImuConfig:
    bus: str
    timeout: float = 0.05  # s without a valid frame: fault


@dataclass(frozen=True)
class SafetyConfig:
    reply_timeout: float = 0.05  # s: a motor whose newest reply is older is a fault
    cycle_timeout: float = 0.003  # s: how long one cycle waits for the replies
    max_position_step: float = 0.3  # rad: largest change of a position target between cycles
    max_temperature: float = 85.0  # deg C
    damping_kd: float = DAMPING_KD  # N m s/rad, joint side, while damping
    soft_start_time: float = 3.0  # s: ramp to the default pose on activate
    max_missed_replies: int = 5  # consecutive cycles a motor may miss before it is a fault


@dataclass(frozen=True)
class HardwareConfig:
    buses: dict[str, BusConfig]
    joints: dict[str, JointConfig]
    description: str = ""
    simulated: bool = False  # true: emulators stand behind every bus (virtual CAN, sim://pty ports)
    imu: ImuConfig | None = None
    imu_model: ImuModelConfig | None = None  # simulated only: the emulated IMU's noise and bias (None: the model's defaults)
    safety: SafetyConfig = field(default_factory=SafetyConfig)
    cycle_hz: float = CONTROL_CYCLE_HZ  # bus cycles per second: one command to and one reply from every motor
    # Simulated only: the emulators and MuJoCo in a process of their own on the wall clock (g1ctl robot --buses), every
    # bus a pseudo-terminal ('sim://pty'), CAN as an slcan adapter on one.
    robot_process: bool = False

    def __post_init__(self) -> None:
        if not self.cycle_hz > 0:
            raise ValueError(f"cycle_hz must be positive, got {self.cycle_hz}")


def load_motor_models(path: Path | None = None) -> dict[str, MitRanges]:
    path = path or config_dir() / "motors.yaml"
    data = load_yaml(path)
    if not isinstance(data, dict) or not isinstance(data.get("models"), dict):
        raise ConfigError(f"{path}: expected a 'models' mapping")
    return {name: from_dict(MitRanges, values, str(path), f"models.{name}") for name, values in data["models"].items()}


def available_hardware() -> list[str]:
    return preset_names(config_dir("hardware"))


def hardware_config_path(name_or_path: str) -> Path:
    return resolve_preset(name_or_path, config_dir("hardware"), "hardware config")


def load_hardware_config(name_or_path: str, expected_joints: tuple[str, ...] = JOINT_NAMES) -> HardwareConfig:
    """A bus config (CAN, serial); a DDS config is refused in one line naming the commands that take it."""
    cfg = load_robot_config(name_or_path, expected_joints)
    if isinstance(cfg, DdsHardwareConfig):
        raise ConfigError(
            f"hardware config '{name_or_path}' is a G1 over DDS: this command drives CAN/serial buses; "
            "'g1ctl sim', 'g1ctl run', 'g1ctl hw' and 'g1ctl bench dds' take DDS configs"
        )
    return cfg


def load_robot_config(name_or_path: str, expected_joints: tuple[str, ...] = JOINT_NAMES) -> HardwareConfig | DdsHardwareConfig:
    """Any hardware config: buses with a joint map (`HardwareConfig`), or a G1 over DDS (`transport: dds`)."""
    path = hardware_config_path(name_or_path)
    data = load_yaml(path)
    if is_dds_config(data):
        return dds_config_from(data, str(path), expected_joints)
    cfg = from_dict(HardwareConfig, with_g1_joint_table(data), str(path))
    validate(cfg, str(path), expected_joints, load_motor_models())
    return cfg


def validate(cfg: HardwareConfig, source: str, expected_joints: tuple[str, ...], models: dict[str, MitRanges]) -> None:
    check_imu_model(cfg.imu_model, cfg.simulated, source)
    if cfg.robot_process:
        check_robot_process(cfg, source)
    elif cfg.simulated and not (CONTROL_CYCLE_HZ / cfg.cycle_hz).is_integer():
        raise ConfigError(
            f"{source}: cycle_hz: simulated buses cycle in lockstep with the {CONTROL_CYCLE_HZ:g} Hz physics, "
            f"so the rate must divide it (500, 250, 125, ...), got {cfg.cycle_hz:g}"
        )
    missing = [j for j in expected_joints if j not in cfg.joints]
    if missing:
        raise ConfigError(f"{source}: joints missing from the joint map: {', '.join(missing)}")
    unknown = [j for j in cfg.joints if j not in expected_joints]
    if unknown:
        raise ConfigError(f"{source}: unknown joints in the joint map: {', '.join(unknown)}")
    check_within_g1_limits(cfg.joints, source)
    seen: dict[tuple[str, int], str] = {}
    for name, joint in cfg.joints.items():
        if joint.bus not in cfg.buses:
            raise ConfigError(f"{source}: joints.{name}.bus: no bus '{joint.bus}' (buses: {', '.join(cfg.buses)})")
        bus = cfg.buses[joint.bus]
        wanted = "can" if joint.protocol == "mit" else "serial"
        if bus.kind != wanted:
            raise ConfigError(f"{source}: joints.{name}: protocol {joint.protocol} needs a {wanted} bus, '{joint.bus}' is {bus.kind}")
        if joint.protocol == "mit" and joint.model not in models:
            raise ConfigError(f"{source}: joints.{name}.model: unknown motor model '{joint.model}' (known: {', '.join(models)})")
        if joint.protocol == "mit":
            variants = {j.reply for j in cfg.joints.values() if j.bus == joint.bus}
            if "damiao" in variants and len(variants) > 1:
                raise ConfigError(
                    f"{source}: bus '{joint.bus}' mixes damiao replies with {', '.join(sorted(variants - {'damiao'}))}: "
                    "their first bytes collide (state nibble plus id); give the Damiao motors a bus of their own"
                )
        key = (joint.bus, joint.id)
        if key in seen:
            raise ConfigError(f"{source}: joints {seen[key]} and {name} share motor id {joint.id} on bus '{joint.bus}'")
        seen[key] = name
    if cfg.imu is not None:
        if cfg.imu.bus not in cfg.buses or cfg.buses[cfg.imu.bus].kind != "serial":
            raise ConfigError(f"{source}: imu.bus: '{cfg.imu.bus}' is not a serial bus of this config")
        if any(j.bus == cfg.imu.bus for j in cfg.joints.values()):
            raise ConfigError(f"{source}: imu.bus: '{cfg.imu.bus}' is shared with motors; give the IMU its own port")
    elif cfg.imu_model is not None:
        raise ConfigError(f"{source}: imu_model: this config has no IMU to model (add an 'imu' section with its serial bus)")


def check_robot_process(cfg: HardwareConfig, source: str) -> None:
    """A bus robot in its own process is simulated, and the process makes every port: a pseudo-terminal each."""
    if not cfg.simulated:
        raise ConfigError(f"{source}: robot_process: a robot process is a simulated one (simulated: true)")
    for name, bus in cfg.buses.items():
        where, given = ("channel", bus.channel) if bus.kind == "can" else ("port", bus.port)
        if (bus.kind == "can" and bus.interface != "slcan") or given != "sim://pty":
            wanted = "interface: slcan, channel: 'sim://pty'" if bus.kind == "can" else "port: 'sim://pty'"
            raise ConfigError(f"{source}: buses.{name}: the robot process makes its ports ({wanted}), this one has {where} '{given}'")
