"""The command every motor protocol carries, decoded: one type for the MIT and RS-485 codecs,
the host side and the firmware emulators alike."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class MotorCommand:
    """Motor-side PD command (rotor units): tau = kp (position - q) + kd (velocity - dq) + torque."""

    position: float
    velocity: float
    kp: float
    kd: float
    torque: float
