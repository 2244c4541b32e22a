"""The state machine of one emulated motor, common to both protocols (motor-side units).

Firmware behaviour emulated: motor mode on/off, a command watchdog after which the motor
goes limp, set-zero, temperature that rises with the square of the current and cools
towards ambient, error codes that latch until motor mode is re-entered (or, for RS-485,
until a brake command), and a seized output for the stuck-motor drill.
"""

from __future__ import annotations

from dataclasses import dataclass

from hw.emulation.plant import Plant
from hw.emulation.wire_audit import MotorState, WireAudit
from hw.jointmap import JointConfig, joint_to_motor, motor_to_joint
from hw.protocols.command import MotorCommand

AMBIENT_C = 30.0
HEATING_C_PER_S = 5.0  # at the motor's full torque
COOLING_TIME_S = 60.0
OVER_TEMPERATURE_C = 95.0
SEIZED_KD = 500.0  # N m s/rad, joint side: damping so stiff that a seized output stays where it is


@dataclass
class EmulatedMotor:
    joint_name: str
    joint: JointConfig
    torque_max: float  # motor side, for the heating model
    watchdog_s: float = 0.1
    enabled: bool = False
    encoder_zero: float = 0.0  # motor-side position that reads as zero
    temperature: float = AMBIENT_C
    error_code: int = 0
    last_command_time: float | None = None
    stalled_torque: float | None = None  # motor side: what a seized motor's controller pushes
    audit: WireAudit | None = None  # told each control step what this motor decoded and what state it is in
    _last_command: MotorCommand | None = None
    _thermal_time: float | None = None
    _state: MotorState = "limp"

    def apply(self, plant: Plant, command: MotorCommand | None, over_temperature_code: int, stuck: bool) -> None:
        """Take a new command (None: keep the last) and push the resulting PD law into the plant."""
        now = plant.time()
        self._heat(plant, now)
        if self.temperature > OVER_TEMPERATURE_C and self.error_code == 0:
            self.error_code = over_temperature_code
        if command is not None:
            self.last_command_time, self._last_command = now, command
        expired = self.last_command_time is None or now - self.last_command_time > self.watchdog_s
        self.stalled_torque = None
        joint_command = None
        if command is not None:
            q, dq, tau = motor_to_joint(self.joint, command.position + self.encoder_zero, command.velocity, command.torque)
            g2 = self.joint.gear_ratio**2
            joint_command = (q, dq, command.kp * g2, command.kd * g2, tau)
        if stuck:
            # The output is seized: the joint does not move, and the motor's own PD pushes
            # against the seizure, so its current (the reported torque) grows with the error.
            plant.set_joint_command(self.joint_name, plant.joint_state(self.joint_name)[0], 0.0, 0.0, SEIZED_KD, 0.0)
            c = self._last_command
            if c is not None and self.enabled:
                position, velocity, _ = self.reading(plant)
                pushed = c.kp * (c.position - position) + c.kd * (c.velocity - velocity) + c.torque
                self.stalled_torque = max(-self.torque_max, min(self.torque_max, pushed))
            self._state = "seized"
        elif not self.enabled or self.error_code != 0 or (command is None and expired):
            plant.set_joint_command(self.joint_name, 0.0, 0.0, 0.0, 0.0, 0.0)  # limp
            self._state = "limp"
        elif joint_command is not None:
            q, dq, kp, kd, tau = joint_command
            plant.set_joint_command(self.joint_name, q, dq, kp, kd, tau)
            self._state = "active" if kp > 0 else ("damping" if kd > 0 else "limp")
        if self.audit is not None:
            wire = None if joint_command is None else (joint_command[0], joint_command[1], joint_command[2], joint_command[4])
            self.audit.motor_step(self.joint_name, now, self._state, wire)

    def _heat(self, plant: Plant, now: float) -> None:
        if self._thermal_time is not None and now > self._thermal_time:
            dt = now - self._thermal_time
            torque = abs(plant.joint_state(self.joint_name)[2]) / self.joint.gear_ratio
            load = min(torque / self.torque_max, 1.5) if self.torque_max > 0 else 0.0
            self.temperature += dt * (HEATING_C_PER_S * load * load - (self.temperature - AMBIENT_C) / COOLING_TIME_S)
        self._thermal_time = now

    def reading(self, plant: Plant) -> tuple[float, float, float]:
        """Motor-side position (relative to the encoder zero), velocity and torque."""
        position, velocity, torque = joint_to_motor(self.joint, *plant.joint_state(self.joint_name))
        return position - self.encoder_zero, velocity, self.stalled_torque if self.stalled_torque is not None else torque

    def set_zero(self, plant: Plant) -> None:
        position, _, _ = self.reading(plant)
        self.encoder_zero += position
