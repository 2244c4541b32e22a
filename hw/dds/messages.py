"""The G1's low-level messages as Cyclone DDS types, and their conversion to the packed records the CRC is taken over.

The type names and fields are those of the robot's IDL (`unitree_hg::msg::dds_`, see
`hw.protocols.unitree_hg`): a participant publishing these on `rt/lowcmd` is understood by the
robot. DDS serializes them (CDR); the CRC is computed, as the robot does, over the C layout of
the same fields (numpy records). The control path writes and reads CDR straight from the
records (`hw.dds.cdr`); the record conversions here go through Cyclone's own serializer and
are the reference the tests hold `cdr` to.
Needs the `g1` extra (`pip install -e '.[g1]'`: cyclonedds). No `from __future__ import
annotations` here: cyclonedds reads the field types from the annotations themselves.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

from hw.dds import EXTRA_HINT
from hw.errors import ConfigError
from hw.protocols import unitree_hg as hg

try:
    from cyclonedds.idl import IdlStruct, types
    from cyclonedds.idl import annotations as annotate
except ImportError as exc:  # one line naming the extra
    raise ConfigError(EXTRA_HINT) from exc

_MODULE = "unitree_hg.msg.dds_"
_MOTOR_CMD_FIELDS = hg.MOTOR_CMD.names or ()
_MOTOR_STATE_FIELDS = hg.MOTOR_STATE.names or ()
_IMU_FIELDS = hg.IMU_STATE.names or ()


@dataclass
@annotate.final
class MotorCmd_(IdlStruct, typename=f"{_MODULE}.MotorCmd_"):
    mode: types.uint8
    q: types.float32
    dq: types.float32
    tau: types.float32
    kp: types.float32
    kd: types.float32
    reserve: types.uint32


@dataclass
@annotate.final
class LowCmd_(IdlStruct, typename=f"{_MODULE}.LowCmd_"):
    mode_pr: types.uint8
    mode_machine: types.uint8
    motor_cmd: types.array[MotorCmd_, 35]
    reserve: types.array[types.uint32, 4]
    crc: types.uint32


@dataclass
@annotate.final
class IMUState_(IdlStruct, typename=f"{_MODULE}.IMUState_"):
    quaternion: types.array[types.float32, 4]
    gyroscope: types.array[types.float32, 3]
    accelerometer: types.array[types.float32, 3]
    rpy: types.array[types.float32, 3]
    temperature: types.int16


@dataclass
@annotate.final
class MotorState_(IdlStruct, typename=f"{_MODULE}.MotorState_"):
    mode: types.uint8
    q: types.float32
    dq: types.float32
    ddq: types.float32
    tau_est: types.float32
    temperature: types.array[types.int16, 2]
    vol: types.float32
    sensor: types.array[types.uint32, 2]
    motorstate: types.uint32
    reserve: types.array[types.uint32, 4]


@dataclass
@annotate.final
class LowState_(IdlStruct, typename=f"{_MODULE}.LowState_"):
    version: types.array[types.uint32, 2]
    mode_pr: types.uint8
    mode_machine: types.uint8
    tick: types.uint32
    imu_state: IMUState_
    motor_state: types.array[MotorState_, 35]
    wireless_remote: types.array[types.uint8, 40]
    reserve: types.array[types.uint32, 4]
    crc: types.uint32


def _values(value: Any) -> Any:
    """A numpy field as plain Python (lists of ints and floats), as the IDL types take it."""
    return value.tolist() if isinstance(value, np.ndarray) else value.item()


def low_cmd_from_record(record: np.ndarray) -> LowCmd_:
    """A packed `LowCmd_` record (its CRC already set: `hg.with_crc`) as the DDS message."""
    motors = [MotorCmd_(*(_values(slot[name]) for name in _MOTOR_CMD_FIELDS)) for slot in record["motor_cmd"]]
    return LowCmd_(int(record["mode_pr"]), int(record["mode_machine"]), motors, _values(record["reserve"]), int(record["crc"]))


def low_cmd_to_record(message: LowCmd_) -> np.ndarray:
    """The DDS message as a `LowCmd_` record (CRC as received: check it with `hg.crc_ok`)."""
    record = np.zeros((), dtype=hg.LOW_CMD)
    record["mode_pr"], record["mode_machine"], record["crc"] = message.mode_pr, message.mode_machine, message.crc
    record["reserve"] = message.reserve
    record["motor_cmd"] = [tuple(getattr(m, name) for name in _MOTOR_CMD_FIELDS) for m in message.motor_cmd]
    return record


def low_state_from_record(record: np.ndarray) -> LowState_:
    imu = record["imu_state"]
    motors = [MotorState_(*(_values(m[name]) for name in _MOTOR_STATE_FIELDS)) for m in record["motor_state"]]
    return LowState_(
        _values(record["version"]), int(record["mode_pr"]), int(record["mode_machine"]), int(record["tick"]),
        IMUState_(*(_values(imu[name]) for name in _IMU_FIELDS)), motors, _values(record["wireless_remote"]),
        _values(record["reserve"]), int(record["crc"]),
    )  # fmt: skip


def low_state_to_record(message: LowState_) -> np.ndarray:
    record = np.zeros((), dtype=hg.LOW_STATE)
    record["version"], record["mode_pr"], record["mode_machine"] = message.version, message.mode_pr, message.mode_machine
    record["tick"], record["crc"], record["reserve"] = message.tick, message.crc, message.reserve
    imu = message.imu_state
    record["imu_state"] = tuple(getattr(imu, name) for name in _IMU_FIELDS)
    record["motor_state"] = [tuple(getattr(m, name) for name in _MOTOR_STATE_FIELDS) for m in message.motor_state]
    remote = message.wireless_remote  # a uint8 array arrives as bytes
    record["wireless_remote"] = np.frombuffer(remote, dtype=np.uint8) if isinstance(remote, bytes | bytearray) else remote
    return record
