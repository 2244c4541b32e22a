"""The bench interface (`hw.bench.BenchRobot`) on a robot on CAN and RS-485 buses (`HardwareRobot`).

Each motor answers for itself, so a scan reads every motor's newest reply (or that none came), and
the IMU is the serial one of the config. MIT motors take an encoder-zero command; RS-485 motors
have none, and a zero gives the joint map's `zero_offset` that does it instead.
"""

from __future__ import annotations

from hw.bench import BenchRobot, JointStatus, Pump, ZeroResult
from hw.drivers import MitBusDriver
from hw.errors import ConfigError
from hw.hardware_robot import HardwareRobot
from hw.jointmap import motor_to_joint
from hw.protocols import mit


class BusBenchRobot(BenchRobot):
    """A robot on CAN and RS-485 buses (`HardwareRobot`), real or simulated."""

    transport = "buses"
    SCAN_COLUMNS = ("bus", "id", "joint", "answered", "q", "temperature", "error")

    def __init__(self, host: HardwareRobot, pump: Pump, config_name: str) -> None:
        super().__init__(host, host.cfg.joints, pump, config_name, host.cfg.safety.max_temperature)
        self.host = host

    def status(self) -> list[JointStatus]:
        now = self.host.stamp_clock()
        rows = []
        for name in self.joint_names:
            joint = self.host.cfg.joints[name]
            fb = self.host.feedback(name)
            answered = fb.stamp is not None
            q, dq, tau = motor_to_joint(joint, fb.position, fb.velocity, fb.torque) if answered else (None, None, None)
            hot = fb.temperature is not None and fb.temperature > self.max_temperature
            age = None if fb.stamp is None else round(1e3 * (now - fb.stamp), 1)
            healthy = answered and not fb.faulted and not hot
            rows.append(JointStatus(name, joint.bus, joint.id, answered, q, dq, tau, fb.temperature, fb.error, healthy, age))
        return rows

    def _silent_motors(self) -> dict[str, str]:
        joints = self.host.cfg.joints
        return {n: f"bus {joints[n].bus}, id {joints[n].id}" for n in self.joint_names if self.host.feedback(n).stamp is None}

    def _zero(self, joint: str) -> ZeroResult:
        """MIT motors: the encoder zero set on the motor. RS-485 motors have no zero command: the joint map's
        `zero_offset` that makes the current position read 0."""
        driver = self.host.driver_of(joint)
        cfg = self.host.cfg.joints[joint]
        if isinstance(driver, MitBusDriver):
            driver.send_special(mit.SET_ZERO, (cfg.id,))
            driver.collect_now(0.02)
            return ZeroResult(joint, "encoder zero set on the motor", None)
        fb = self.host.feedback(joint)
        position = motor_to_joint(cfg, fb.position, 0.0, 0.0)[0] - cfg.zero_offset
        return ZeroResult(joint, "no zero command on this protocol: set zero_offset in the joint map", round(-position, 6))

    def _imu_stamp(self) -> float | None:
        if self.host.imu is None:
            raise ConfigError(f"hardware config '{self.config_name}' has no IMU (add an 'imu' section with its serial bus)")
        return self.host.imu.stamp

    def _imu_counts(self) -> tuple[int, int, int | None]:
        if self.host.imu is None:
            return 0, 0, None
        c = self.host.imu.counters
        return c.frames, c.crc_errors, c.sequence_gaps

    def _imu_silent(self, seconds: float) -> str:
        name = "-" if self.host.imu is None else self.host.imu.name
        return f"no valid IMU frame in {seconds} s on serial port '{name}'; check the port, baud rate and wiring"
