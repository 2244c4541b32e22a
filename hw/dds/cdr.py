"""`LowCmd_` and `LowState_` in CDR (what goes on the DDS wire) straight from and to the packed records, in numpy.

Cyclone DDS's Python serializer walks the 35 nested motor structs field by field: 0.26 ms to
serialize a `LowCmd_` and 0.77 ms to read a `LowState_`, half the 2 ms control cycle. These
are fixed-size `@final` structs of primitives (16-33 µs a message here), so their CDR (XCDR1, little-endian) is a fixed
layout: a 4-byte encapsulation header, then every field aligned to its own size counted
from the start of the body, with no padding at the end of a nested struct. It differs from
the C layout only there: a motor's `mode` byte follows the previous motor's last word
directly (the first motor's `mode` sits at body offset 2 in `LowCmd_`, 70 in `LowState_`).
The tests check these bytes against Cyclone DDS's own serializer.
"""

from __future__ import annotations

import array
import struct
import sys
import zlib
from typing import Any, NamedTuple

import numpy as np

from hw.protocols import unitree_hg as hg
from hw.protocols.crc import BIT_REVERSE_TABLE, FrameError, crc32_from_zlib

CDR_LE = b"\x00\x01\x00\x00"  # encapsulation: plain CDR, little-endian
LOW_CMD_BODY = 1000
LOW_STATE_BODY = 2088

# Motor fields after the `mode` byte, at their offsets within a 28- (56-) byte stride.
_CMD_MOTOR = np.dtype(
    {"names": ["q", "dq", "tau", "kp", "kd", "reserve"], "formats": ["<f4"] * 5 + ["<u4"], "offsets": [4, 8, 12, 16, 20, 24],
     "itemsize": 28}
)  # fmt: skip
_STATE_MOTOR = np.dtype(
    {"names": ["q", "dq", "ddq", "tau_est", "temperature", "vol", "sensor", "motorstate", "reserve"],
     "formats": ["<f4", "<f4", "<f4", "<f4", ("<i2", (2,)), "<f4", ("<u4", (2,)), "<u4", ("<u4", (4,))],
     "offsets": [4, 8, 12, 16, 20, 24, 28, 36, 40], "itemsize": 56}
)  # fmt: skip
_STATE_MOTORS_AT = 68  # the motor array's stride starts here: motor i's `q` at 72 + 56 i
_STATE_HEAD = np.dtype(
    {"names": ["version", "mode_pr", "mode_machine", "tick", "quaternion", "gyroscope", "accelerometer", "rpy", "imu_temperature"],
     "formats": [("<u4", (2,)), "u1", "u1", "<u4", ("<f4", (4,)), ("<f4", (3,)), ("<f4", (3,)), ("<f4", (3,)), "<i2"],
     "offsets": [0, 8, 9, 12, 16, 32, 44, 56, 68], "itemsize": 70}
)  # fmt: skip
_STATE_TAIL = np.dtype(
    {"names": ["wireless_remote", "reserve", "crc"], "formats": [("u1", (40,)), ("<u4", (4,)), "<u4"], "offsets": [0, 40, 56],
     "itemsize": 60}
)  # fmt: skip
_STATE_TAIL_AT = 2028
_IMU = ("quaternion", "gyroscope", "accelerometer", "rpy")


def _modes_at(first: int, stride: int, count: int) -> np.ndarray:
    """Body offsets of each motor's `mode` byte: the first right after the header fields, the rest one stride apart."""
    at = first + stride * np.arange(count)
    at[1:] = (first - first % 4) + stride * np.arange(1, count)  # each later one where the previous struct ended
    return at


_CMD_MODES = _modes_at(2, 28, hg.NUM_MOTORS)  # 2, 28, 56, ...
_STATE_MODES = _modes_at(70, 56, hg.NUM_MOTORS)  # 70, 124, 180, ...


def _cmd_fields(record: np.ndarray, body: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(record field, CDR body view) pairs of a `LowCmd_`, every field but the motors' `mode` bytes."""
    motors = np.ndarray((hg.NUM_MOTORS,), dtype=_CMD_MOTOR, buffer=body)
    pairs = [(record["mode_pr"], body[0:1]), (record["mode_machine"], body[1:2])]
    pairs += [(record["motor_cmd"][name], motors[name]) for name in _CMD_MOTOR.names or ()]
    return [*pairs, (record["reserve"], body[980:996].view("<u4")), (record["crc"], body[996:1000].view("<u4"))]


def _state_fields(record: np.ndarray, body: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(record field, CDR body view) pairs of a `LowState_`, every field but the motors' `mode` bytes."""
    head = np.ndarray((), dtype=_STATE_HEAD, buffer=body)
    motors = np.ndarray((hg.NUM_MOTORS,), dtype=_STATE_MOTOR, buffer=body, offset=_STATE_MOTORS_AT)
    tail = np.ndarray((), dtype=_STATE_TAIL, buffer=body, offset=_STATE_TAIL_AT)
    imu = record["imu_state"]
    pairs = [(record[name], head[name]) for name in ("version", "mode_pr", "mode_machine", "tick")]
    pairs += [(imu[name], head[name]) for name in _IMU] + [(imu["temperature"], head["imu_temperature"])]
    pairs += [(record["motor_state"][name], motors[name]) for name in _STATE_MOTOR.names or ()]
    return pairs + [(record[name], tail[name]) for name in ("wireless_remote", "reserve", "crc")]


def _encode_by_fields(record: np.ndarray, size: int, fields: Any, motors: str, modes: np.ndarray) -> np.ndarray:
    body = np.zeros(size, dtype=np.uint8)
    for source, target in fields(record, body):
        target[...] = np.reshape(source, target.shape)
    body[modes] = record[motors]["mode"]
    return body


def _byte_maps(dtype: np.dtype[Any], size: int, fields: Any, motors: str, modes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each CDR body byte comes from in the packed record, and the reverse; padding points one past the end (a zero).

    Both layouts are fixed, so the conversion is a byte permutation: the field table is run once
    on records whose bytes are their own positions (low, then high byte), and each message is
    then one gather of about 2 kB (a few microseconds instead of a walk over the fields).
    """
    position = np.arange(dtype.itemsize)

    def encoded(labels: np.ndarray) -> np.ndarray:
        return _encode_by_fields(np.frombuffer(labels.astype(np.uint8).tobytes(), dtype=dtype).reshape(()), size, fields, motors, modes)

    low, high, filled = encoded(position & 0xFF), encoded(position >> 8), encoded(np.full(dtype.itemsize, 0xFF))
    to_cdr = np.where(filled == 0xFF, low.astype(np.int64) | (high.astype(np.int64) << 8), dtype.itemsize)
    from_cdr = np.full(dtype.itemsize, size)
    carried = to_cdr < dtype.itemsize
    from_cdr[to_cdr[carried]] = np.flatnonzero(carried)
    return to_cdr, from_cdr


_CMD_TO_CDR, _CMD_FROM_CDR = _byte_maps(hg.LOW_CMD, LOW_CMD_BODY, _cmd_fields, "motor_cmd", _CMD_MODES)
_STATE_TO_CDR, _STATE_FROM_CDR = _byte_maps(hg.LOW_STATE, LOW_STATE_BODY, _state_fields, "motor_state", _STATE_MODES)
_ZERO = np.zeros(1, dtype=np.uint8)


def _from_message(from_cdr: np.ndarray, body_size: int) -> np.ndarray:
    """The decoding gather as indices into the whole message: past the 4-byte header, padding on its first byte (always 0)."""
    return np.where(from_cdr == body_size, -4, from_cdr).astype(np.intp) + 4


_CMD_GATHER = _from_message(_CMD_FROM_CDR, LOW_CMD_BODY)
_STATE_GATHER = _from_message(_STATE_FROM_CDR, LOW_STATE_BODY)


def _field_offset(dtype: np.dtype[Any], name: str) -> int:
    fields = dtype.fields
    assert fields is not None
    return int(fields[name][1])


# Where a LowState_ CDR message holds what the host reads every cycle (motor 0's fields; the others one stride on).
MODE_MACHINE_AT = 4 + _field_offset(_STATE_HEAD, "mode_machine")
_Q_AT, _TEMPERATURE_AT, _MOTORSTATE_AT = (4 + _STATE_MOTORS_AT + _field_offset(_STATE_MOTOR, f) for f in ("q", "temperature", "motorstate"))
_IMU_AT = 4 + _field_offset(_STATE_HEAD, "quaternion")
# Per joint from `q`: temperature[2] and motorstate (skipping q, dq, ddq, tau_est, vol, sensor), on to the next `q`.
_HEALTH = struct.Struct("<" + "16x2h12xI20x" * hg.NUM_JOINTS)
if _MOTORSTATE_AT - _Q_AT != 32 or _TEMPERATURE_AT - _Q_AT != 16 or _HEALTH.size != hg.NUM_JOINTS * _STATE_MOTOR.itemsize:
    raise RuntimeError("the LowState_ health layout no longer matches the CDR layout")


class StateHealth(NamedTuple):
    max_temperature: int  # deg C, the hottest of the 29 motors' sensors
    error_bits: bool  # some motor reports a non-zero motorstate


def state_health(data: bytes) -> StateHealth:
    """What the 500 Hz checks need of a (CRC-checked) `LowState_`, read with one `struct` call (87 integers, no floats)."""
    values = _HEALTH.unpack_from(data, _Q_AT)
    return StateHealth(max(max(values[0::3]), max(values[1::3])), any(values[2::3]))


class JointArrays(NamedTuple):
    """The 29 joints of a `LowState_` as strided views into its CDR (no copy): for reading, not for the 500 Hz checks."""

    motion: np.ndarray  # (29, 4) float32: q, dq, ddq, tau_est
    temperature: np.ndarray  # (29, 2) int16: the motor's two sensors
    motorstate: np.ndarray  # (29,) uint32: error bits, 0 when healthy
    imu: np.ndarray  # (13,) float32: quaternion w x y z, gyroscope, accelerometer, rpy


def joint_arrays(data: bytes) -> JointArrays:
    """Strided views of a checked `LowState_` CDR message (`low_state_crc_ok` first)."""
    n, stride = hg.NUM_JOINTS, _STATE_MOTOR.itemsize
    return JointArrays(
        motion=np.ndarray((n, 4), dtype="<f4", buffer=data, offset=_Q_AT, strides=(stride, 4)),
        temperature=np.ndarray((n, 2), dtype="<i2", buffer=data, offset=_TEMPERATURE_AT, strides=(stride, 2)),
        motorstate=np.ndarray((n,), dtype="<u4", buffer=data, offset=_MOTORSTATE_AT, strides=(stride,)),
        imu=np.ndarray((13,), dtype="<f4", buffer=data, offset=_IMU_AT),
    )


# The packed LowState_ and its CDR body hold the same 4-byte words in the same order but for one place: motor 0's
# `mode` sits in the CDR's word 17 (beside the IMU temperature, where the packed record has padding) instead of a word
# of its own after it. So the CRC's input is the body's words with that word split in two, and no gather is needed.
_MODE0_WORD = int(_STATE_MODES[0]) // 4  # 17
_BODY_WORDS = LOW_STATE_BODY // 4  # 522: the last is the CRC
if int(_STATE_MODES[0]) % 4 != 2 or _BODY_WORDS * 4 != LOW_STATE_BODY:
    raise RuntimeError("the LowState_ CRC runs no longer match the CDR layout")


def low_state_crc_ok(data: bytes) -> bool:
    """Whether a `LowState_`'s CRC matches, computed straight from its CDR (the record is never built).

    The host runs this on every state at 500 Hz, so it is a handful of C calls and no numpy: the bytes
    bit-reversed (`bytes.translate`), each word turned most significant byte first (`array.byteswap`),
    motor 0's mode moved to its own word, all fed to zlib.
    """
    _check_message(data, 4 + LOW_STATE_BODY, "LowState_")
    words = array.array("I", data[4 : 4 + LOW_STATE_BODY].translate(BIT_REVERSE_TABLE))
    if sys.byteorder == "little":
        words.byteswap()  # each word's bytes most significant first, as the CRC reads them
    split = words[_MODE0_WORD]  # its bytes [0, mode, t1, t0] -> [0, 0, t1, t0] and a word of its own [0, 0, 0, mode]
    words[_MODE0_WORD] = split & 0xFFFF00FF
    words.insert(_MODE0_WORD + 1, (split & 0x0000FF00) << 16)
    stored = int.from_bytes(data[4 + LOW_STATE_BODY - 4 : 4 + LOW_STATE_BODY], "little")
    return stored == crc32_from_zlib(zlib.crc32(memoryview(words)[:_BODY_WORDS]))  # the packed words but the CRC's own


def _check_message(data: bytes, size: int, what: str) -> None:
    if len(data) < size:
        raise FrameError(f"{what} CDR must be {size} bytes, got {len(data)}")
    if data[0] != CDR_LE[0] or data[1] != CDR_LE[1]:
        raise FrameError(f"{what} CDR encapsulation {data[:2].hex()} is not plain little-endian CDR (0001)")


def _encode(record: np.ndarray, to_cdr: np.ndarray) -> bytes:
    packed = np.concatenate((np.frombuffer(record.tobytes(), dtype=np.uint8), _ZERO))
    return CDR_LE + packed[to_cdr].tobytes()


def _decode(data: Any, gather: np.ndarray, dtype: np.dtype[Any], body_size: int, what: str) -> np.ndarray:
    """One gather from the message: the packed record, padding zero (as the CRC wants it), in a fresh array."""
    data = bytes(data)
    _check_message(data, 4 + body_size, what)
    return np.frombuffer(data, dtype=np.uint8)[gather].view(dtype).reshape(())


def low_cmd_to_cdr(record: np.ndarray) -> bytes:
    """A `LowCmd_` record (CRC set) as the CDR the robot reads."""
    return _encode(record, _CMD_TO_CDR)


def low_cmd_from_cdr(data: bytes | bytearray | memoryview) -> np.ndarray:
    """CDR -> `LowCmd_` record (the CRC as sent: check it with `hg.crc_ok`)."""
    return _decode(data, _CMD_GATHER, hg.LOW_CMD, LOW_CMD_BODY, "LowCmd_")


def low_state_to_cdr(record: np.ndarray) -> bytes:
    """A `LowState_` record (CRC set) as the CDR the robot publishes."""
    return _encode(record, _STATE_TO_CDR)


def low_state_from_cdr(data: bytes | bytearray | memoryview) -> np.ndarray:
    """CDR -> `LowState_` record (the CRC as sent: check it with `hg.crc_ok`)."""
    return _decode(data, _STATE_GATHER, hg.LOW_STATE, LOW_STATE_BODY, "LowState_")
