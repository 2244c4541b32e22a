"""The G1's low-level controller, emulated: `LowCmd_` in, PD laws on the plant, `LowState_` out.

What the robot's main board does with the DDS messages, without the transport (the
simulated robot process puts this behind `rt/lowcmd` and `rt/lowstate`):

- A `LowCmd_` whose CRC does not match, or whose `mode_machine` is not the robot's, is
  refused (counted) and the robot goes limp: zero gains on every joint.
- Motor slot i < 29 with `mode` 1 applies tau = tau_ff + kp (q - q_meas) + kd (dq - dq_meas)
  on joint i; any other mode leaves that joint limp.
- No valid command for `command_timeout_s` (the host died, the cable came out): limp until
  the next valid one.
- `low_state()` samples the plant: joint positions, velocities and torques, the IMU (as its
  error model measures it), a millisecond tick, temperatures, the remote's 40 bytes, the CRC.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hw import g1
from hw.emulation.imu_model import NO_FAULT, ImuBias, ImuModel
from hw.emulation.plant import Plant
from hw.emulation.wire_audit import MotorState, WireAudit
from hw.errors import ConfigError
from hw.protocols import unitree_hg as hg


@dataclass(frozen=True)
class LowLevelConfig:
    mode_machine: int = 5  # the robot's type code, reported in every LowState_; the host copies it into LowCmd_
    command_timeout_s: float = 0.1  # no valid LowCmd_ for this long: limp
    motor_temperature_c: int = 38  # what the emulated motors report (no thermal model here)
    voltage_v: float = 50.4  # battery voltage on every motor

    def __post_init__(self) -> None:
        if not 0 <= self.mode_machine <= 255:
            raise ConfigError(f"mode_machine is a byte (0..255), got {self.mode_machine}")
        if self.command_timeout_s <= 0:
            raise ConfigError(f"command_timeout_s must be positive, got {self.command_timeout_s}")


@dataclass
class LowLevelCounters:
    commands: int = 0  # valid LowCmd_ taken
    crc_errors: int = 0
    mode_machine_mismatches: int = 0
    timeouts: int = 0  # gaps past the command timeout (each counted once)
    damping_commands: int = 0  # valid commands that enable every joint with zero stiffness and some damping: a host's safe state


class G1LowLevel:
    """One robot's low-level loop over a `Plant`; `receive` takes commands, `tick` applies them, `low_state` reports."""

    def __init__(
        self, plant: Plant, cfg: LowLevelConfig = LowLevelConfig(), audit: WireAudit | None = None, imu: ImuModel | None = None
    ) -> None:
        """`audit`: told every command taken and each joint's state per tick (what a drill is judged on).
        `imu`: how the IMU measures the plant's reading (None: as it is)."""
        self.plant = plant
        self.cfg = cfg
        self.audit = audit
        self.imu = imu
        self.counters = LowLevelCounters()
        self.limp_reason: str | None = "no command yet"
        self._command: np.ndarray | None = None  # the last valid LowCmd_ record
        self._last_valid: float | None = None
        self._start = plant.time()
        self.mode_machine = cfg.mode_machine  # the robot's type code now (a drill may change it)

    def receive(self, record: np.ndarray, now: float) -> None:
        """A `LowCmd_` record as it came off the wire."""
        if not hg.crc_ok(record):
            self.counters.crc_errors += 1
            self._go_limp("a LowCmd_ with a bad CRC")
            return
        if int(record["mode_machine"]) != self.mode_machine:
            self.counters.mode_machine_mismatches += 1
            self._go_limp(f"a LowCmd_ for mode_machine {int(record['mode_machine'])} (this robot is {self.mode_machine})")
            return
        self.counters.commands += 1
        joints = record["motor_cmd"][: g1.NUM_JOINTS]
        if (joints["mode"] == hg.MOTOR_ENABLE).all() and not joints["kp"].any() and (joints["kd"] > 0).all():
            self.counters.damping_commands += 1
        if self.audit is not None:
            enabled = joints["mode"] == hg.MOTOR_ENABLE
            self.audit.robot_command(now, joints["q"], joints["dq"], np.where(enabled, joints["kp"], 0.0), joints["tau"])
        self._command, self._last_valid, self.limp_reason = record, now, None

    def tick(self, now: float) -> None:
        """Once per control step: apply the command in force, or go limp when it is too old."""
        if self._command is not None and self._last_valid is not None and now - self._last_valid > self.cfg.command_timeout_s:
            self.counters.timeouts += 1
            self._go_limp(f"no LowCmd_ for {now - self._last_valid:.3f} s")
        with self.plant.lock:
            for i, joint in enumerate(g1.JOINT_NAMES):
                slot = self._command["motor_cmd"][i] if self._command is not None else None
                state: MotorState = "limp"
                if slot is None or int(slot["mode"]) != hg.MOTOR_ENABLE:
                    self.plant.set_joint_command(joint, 0.0, 0.0, 0.0, 0.0, 0.0)
                else:
                    kp, kd = float(slot["kp"]), float(slot["kd"])
                    self.plant.set_joint_command(joint, float(slot["q"]), float(slot["dq"]), kp, kd, float(slot["tau"]))
                    state = "active" if kp > 0 else "damping" if kd > 0 else "limp"
                if self.audit is not None:
                    self.audit.motor_step(joint, now, state, None)

    def _go_limp(self, reason: str) -> None:
        self._command, self._last_valid, self.limp_reason = None, None, reason

    @property
    def limp(self) -> bool:
        return self._command is None

    def low_state(self, remote: bytes = bytes(40), uptime_s: float | None = None, imu_fault: ImuBias = NO_FAULT) -> np.ndarray:
        """The `LowState_` the robot publishes now (CRC set); `tick` counts milliseconds of `uptime_s` (default: the plant's time).
        `imu_fault`: the bias a fault adds to the IMU now."""
        record = np.zeros((), dtype=hg.LOW_STATE)
        record["mode_machine"] = self.mode_machine
        uptime = self.plant.time() - self._start if uptime_s is None else uptime_s
        record["tick"] = round(uptime * 1000.0) & 0xFFFFFFFF
        with self.plant.lock:
            reading, now = self.plant.imu_reading(), self.plant.time()
            states = [self.plant.joint_state(joint) for joint in g1.JOINT_NAMES]
        quaternion, gyro, accel = reading if self.imu is None else self.imu.measure(reading, now, imu_fault)
        imu = record["imu_state"]
        imu["quaternion"], imu["gyroscope"], imu["accelerometer"] = quaternion, gyro, accel
        imu["rpy"] = roll_pitch_yaw(quaternion)
        imu["temperature"] = self.cfg.motor_temperature_c
        motors = record["motor_state"]
        n = len(states)
        motors["q"][:n], motors["dq"][:n], motors["tau_est"][:n] = np.array(states, dtype=np.float64).T
        motors["mode"][:n] = [int(self._command["motor_cmd"][i]["mode"]) if self._command is not None else 0 for i in range(n)]
        motors["temperature"][:n] = self.cfg.motor_temperature_c
        motors["vol"][:n] = self.cfg.voltage_v
        record["wireless_remote"] = np.frombuffer(remote, dtype=np.uint8)
        return hg.with_crc(record)


def roll_pitch_yaw(quaternion: tuple[float, ...]) -> tuple[float, float, float]:
    """Roll, pitch, yaw (rad, ZYX Euler angles) of a unit quaternion (w, x, y, z), as the robot's IMU reports `rpy`."""
    w, x, y, z = quaternion
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw
