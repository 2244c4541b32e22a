"""Faults a simulated G1 can be told to develop mid-run, for the drills of the DDS backend.

Each is what a host meets on a real robot: `stale` (the robot stops publishing `LowState_`:
cable out, main board hung), `bad-crc` (every state corrupted on the wire), `motor-error` (a
motor reports error bits in `motorstate`), `hot` (a motor past its temperature limit),
`nan` (a joint reads NaN: a broken encoder or firmware), `mode-machine` (the robot reports
another type code and refuses commands stamped with the old one), `exit` (the robot process
dies), `imu-bias` (the IMU's gyro and accelerometer read off by `IMU_BIAS_DRILL`: a bias the
start-up calibration missed, or one a temperature change brought). Given as `KIND@SECONDS`,
counted from the first command the robot takes. Pure functions on `LowState_` records; the
process applies them (`imu-bias` through the IMU's error model, `imu_fault`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hw.emulation.imu_model import NO_FAULT, ImuBias
from hw.errors import ConfigError
from hw.protocols import unitree_hg as hg

KINDS = ("stale", "bad-crc", "motor-error", "hot", "nan", "mode-machine", "exit", "imu-bias")
FAULTY_MOTOR = 3  # left_knee_joint: the drills' motor
MOTOR_ERROR_BITS = 0x0000_0020  # any non-zero motorstate is an error to the host
HOT_C = 95
# About half the zero-rate offset (+-1 deg/s) and the zero-g offset (+-20 mg) a BMI088-class IMU's data sheet allows
# before calibration: 0.29, -0.29, 0.57 deg/s (34 deg/min of heading) and 20-31 mg. configs/faults/imu-bias.yaml states the same.
IMU_BIAS_DRILL = ImuBias(gyro=(0.005, -0.005, 0.01), accel=(0.2, -0.2, 0.3))


@dataclass(frozen=True)
class RobotFault:
    kind: str
    at_s: float  # seconds after the first command the robot took

    @staticmethod
    def parse(text: str) -> RobotFault:
        """`KIND@SECONDS`, e.g. `stale@2.5`; one line listing the kinds when it is wrong."""
        kind, _, at = text.partition("@")
        try:
            seconds = float(at)
        except ValueError:
            seconds = -1.0
        if kind not in KINDS or seconds < 0:
            raise ConfigError(f"robot fault '{text}' must be KIND@SECONDS with KIND one of {', '.join(KINDS)} (e.g. stale@2)")
        return RobotFault(kind, seconds)


def active(faults: tuple[RobotFault, ...], since_first_command: float | None) -> frozenset[str]:
    """The kinds in force `since_first_command` seconds after the first command (none before it)."""
    if since_first_command is None:
        return frozenset()
    return frozenset(f.kind for f in faults if since_first_command >= f.at_s)


def imu_fault(kinds: frozenset[str]) -> ImuBias:
    """The bias the faults in force add to the IMU."""
    return IMU_BIAS_DRILL if "imu-bias" in kinds else NO_FAULT


def tamper(record: np.ndarray, kinds: frozenset[str]) -> np.ndarray:
    """The `LowState_` the faulty robot publishes instead of `record` (CRC recomputed, or broken for `bad-crc`)."""
    if not kinds & {"motor-error", "hot", "nan", "bad-crc"}:
        return record
    out = record.copy()
    if "motor-error" in kinds:
        out["motor_state"]["motorstate"][FAULTY_MOTOR] = MOTOR_ERROR_BITS
    if "hot" in kinds:
        out["motor_state"]["temperature"][FAULTY_MOTOR] = HOT_C
    if "nan" in kinds:
        out["motor_state"]["q"][FAULTY_MOTOR] = np.nan
    out = hg.with_crc(out)
    if "bad-crc" in kinds:
        out["crc"] ^= 0xDEAD
    return out
