"""The Unitree G1's low-level DDS messages (IDL module `unitree_hg::msg::dds_`), packed as the robot packs them.

Layouts from Unitree's public SDK (unitree_sdk2, `unitree_hg` IDL), written out here: C structs
with natural alignment, little-endian.

- `MotorCmd_` {mode u8, q, dq, tau, kp, kd f32, reserve u32}: 28 bytes.
- `LowCmd_` {mode_pr u8, mode_machine u8, motor_cmd MotorCmd_[35], reserve u32[4], crc u32}:
  1004 bytes.
- `IMUState_` {quaternion f32[4] (w, x, y, z), gyroscope f32[3], accelerometer f32[3], rpy f32[3],
  temperature i16}: 56 bytes.
- `MotorState_` {mode u8, q, dq, ddq, tau_est f32, temperature i16[2], vol f32, sensor u32[2],
  motorstate u32, reserve u32[4]}: 56 bytes.
- `LowState_` {version u32[2], mode_pr u8, mode_machine u8, tick u32, imu_state, motor_state[35],
  wireless_remote u8[40], reserve u32[4], crc u32}: 2092 bytes.

The first 29 motor slots are the G1's 29 joints in the standard order (`hw.g1.JOINT_NAMES`). The
CRC covers the message without its last word, read as little-endian uint32 words, each fed most
significant bit first into CRC-32/MPEG-2 (`hw.protocols.crc.crc32_words`). `mode_pr` 0 is the
pitch/roll ankle and waist mode; `mode_machine` is copied from the robot's `LowState_`; a motor
with `mode` 1 is enabled. Pure functions on bytes and numpy records; no DDS here.
"""

from __future__ import annotations

import functools
import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

from hw.protocols.crc import CrcError, FrameError, crc32_words

NUM_MOTORS = 35
NUM_JOINTS = 29  # motor slots 0..28; the rest are unused on the 29-dof G1
MOTOR_ENABLE = 1

MOTOR_CMD = np.dtype(
    [("mode", "u1"), ("q", "<f4"), ("dq", "<f4"), ("tau", "<f4"), ("kp", "<f4"), ("kd", "<f4"), ("reserve", "<u4")], align=True
)
LOW_CMD = np.dtype(
    [("mode_pr", "u1"), ("mode_machine", "u1"), ("motor_cmd", MOTOR_CMD, (NUM_MOTORS,)), ("reserve", "<u4", (4,)), ("crc", "<u4")],
    align=True,
)
IMU_STATE = np.dtype(
    [("quaternion", "<f4", (4,)), ("gyroscope", "<f4", (3,)), ("accelerometer", "<f4", (3,)), ("rpy", "<f4", (3,)),
     ("temperature", "<i2")],
    align=True,
)  # fmt: skip
MOTOR_STATE = np.dtype(
    [("mode", "u1"), ("q", "<f4"), ("dq", "<f4"), ("ddq", "<f4"), ("tau_est", "<f4"), ("temperature", "<i2", (2,)),
     ("vol", "<f4"), ("sensor", "<u4", (2,)), ("motorstate", "<u4"), ("reserve", "<u4", (4,))],
    align=True,
)  # fmt: skip
LOW_STATE = np.dtype(
    [("version", "<u4", (2,)), ("mode_pr", "u1"), ("mode_machine", "u1"), ("tick", "<u4"), ("imu_state", IMU_STATE),
     ("motor_state", MOTOR_STATE, (NUM_MOTORS,)), ("wireless_remote", "u1", (40,)), ("reserve", "<u4", (4,)), ("crc", "<u4")],
    align=True,
)  # fmt: skip
LOW_CMD_SIZE = 1004
LOW_STATE_SIZE = 2092
if LOW_CMD.itemsize != LOW_CMD_SIZE or LOW_STATE.itemsize != LOW_STATE_SIZE:  # the layout is the contract
    raise RuntimeError(f"unitree_hg layouts are {LOW_CMD.itemsize} and {LOW_STATE.itemsize} bytes, not 1004 and 2092")


def message_crc(message: bytes | bytearray | memoryview | np.ndarray) -> int:
    """The CRC of a packed message: every little-endian uint32 word but the last (the CRC's own)."""
    words = np.frombuffer(message, dtype="<u4", count=len(message) // 4 - 1)
    return crc32_words(words)


def new_low_cmd(mode_pr: int = 0, mode_machine: int = 0) -> np.ndarray:
    """A zeroed `LowCmd_` record (every motor disabled) to fill in and `pack`."""
    record = np.zeros((), dtype=LOW_CMD)
    record["mode_pr"], record["mode_machine"] = mode_pr, mode_machine
    return record


def canonical(record: np.ndarray) -> np.ndarray:
    """A copy of `record` whose padding bytes are zero.

    The CRC covers the padding too, and numpy's own copies of aligned records leave it
    uninitialized: every record that is packed or checked goes through here.
    """
    data = np.frombuffer(np.asarray(record).tobytes(), dtype=np.uint8).copy()
    data[_padding(record.dtype)] = 0
    return data.view(record.dtype).reshape(())


@functools.cache
def _padding(dtype: np.dtype[Any]) -> np.ndarray:
    """Byte mask of the padding of a record type: what a leaf-by-leaf copy into zeros leaves zero."""
    full = np.frombuffer(b"\xff" * dtype.itemsize, dtype=dtype).reshape(())
    leaves = np.zeros((), dtype=dtype)
    _copy_fields(leaves, full, dtype)
    return np.frombuffer(leaves.tobytes(), dtype=np.uint8) == 0


def _copy_fields(dst: np.ndarray, src: np.ndarray, dtype: np.dtype[Any]) -> None:
    """Leaf field by leaf field (a whole-record assignment copies the padding too)."""
    for name in dtype.names or ():
        sub = dtype.fields[name][0].base  # type: ignore[index]
        if sub.names:
            _copy_fields(dst[name], src[name], sub)
        else:
            dst[name] = src[name]


def with_crc(record: np.ndarray) -> np.ndarray:
    """A copy of `record` (padding zero) with its CRC field set, ready to send."""
    out = canonical(record)
    out["crc"] = message_crc(out.tobytes())
    return out


def crc_ok(record: np.ndarray, padding_zero: bool = False) -> bool:
    """Whether a record's CRC matches its fields (packed with zero padding: DDS does not carry the padding).

    `padding_zero`: the caller knows the padding is zero already (a record decoded from CDR), which saves a copy.
    """
    packed = record if padding_zero else canonical(record)
    return int(record["crc"]) == message_crc(packed.reshape(1).view(np.uint8) if packed.flags.c_contiguous else packed.tobytes())


def pack(record: np.ndarray) -> bytes:
    """A `LowCmd_` or `LowState_` record as wire bytes (padding zero), its CRC computed and stored last."""
    data = bytearray(canonical(record).tobytes())
    struct.pack_into("<I", data, len(data) - 4, message_crc(data))
    return bytes(data)


def _unpack(data: bytes | bytearray | memoryview, dtype: np.dtype[Any], what: str) -> np.ndarray:
    if len(data) != dtype.itemsize:
        raise FrameError(f"{what} must be {dtype.itemsize} bytes, got {len(data)}")
    stored = struct.unpack_from("<I", data, len(data) - 4)[0]
    computed = message_crc(data)
    if stored != computed:
        raise CrcError(f"{what} CRC mismatch: stored {stored:#010x}, computed {computed:#010x}")
    return canonical(np.frombuffer(bytes(data), dtype=dtype)[0])


def unpack_low_cmd(data: bytes | bytearray | memoryview) -> np.ndarray:
    """Wire bytes -> `LowCmd_` record; `FrameError` on a wrong length, `CrcError` on a wrong CRC."""
    return _unpack(data, LOW_CMD, "LowCmd_")


def unpack_low_state(data: bytes | bytearray | memoryview) -> np.ndarray:
    """Wire bytes -> `LowState_` record; `FrameError` on a wrong length, `CrcError` on a wrong CRC."""
    return _unpack(data, LOW_STATE, "LowState_")


def encode_motor_command(
    motor: int, mode: int, q: float, dq: float, tau: float, kp: float, kd: float, mode_machine: int = 0, mode_pr: int = 0
) -> bytes:
    """A `LowCmd_` with motor slot `motor` set and every other slot zero (the `g1ctl hw frame encode` frame)."""
    if not 0 <= motor < NUM_MOTORS:
        raise FrameError(f"motor index must be 0..{NUM_MOTORS - 1}, got {motor}")
    if not 0 <= mode <= 255 or not 0 <= mode_machine <= 255 or not 0 <= mode_pr <= 255:
        raise FrameError(f"mode, mode_machine and mode_pr are bytes (0..255), got {mode}, {mode_machine}, {mode_pr}")
    record = new_low_cmd(mode_pr, mode_machine)
    slot = record["motor_cmd"][motor]
    slot["mode"], slot["q"], slot["dq"], slot["tau"], slot["kp"], slot["kd"] = mode, q, dq, tau, kp, kd
    return pack(record)


# ---- the robot's wireless remote, in LowState_.wireless_remote ----------------------------------

_BYTE2_BUTTONS = ("R1", "L1", "start", "select", "R2", "L2")  # bit 0 first
_BYTE3_BUTTONS = ("A", "B", "X", "Y", "up", "right", "down", "left")


@dataclass(frozen=True)
class WirelessRemote:
    """The remote's sticks in [-1, 1] (lx, rx right positive; ly, ry up positive) and its held buttons."""

    lx: float = 0.0
    ly: float = 0.0
    rx: float = 0.0
    ry: float = 0.0
    buttons: frozenset[str] = frozenset()


def decode_wireless_remote(data: bytes | bytearray | memoryview | np.ndarray) -> WirelessRemote:
    """The 40 `wireless_remote` bytes: buttons in bytes 2 and 3, float32 sticks lx, rx, ry at 4, 8, 12 and ly at 20."""
    raw = bytes(np.asarray(data, dtype=np.uint8)) if isinstance(data, np.ndarray) else bytes(data)
    if len(raw) != 40:
        raise FrameError(f"wireless_remote must be 40 bytes, got {len(raw)}")
    held = {name for bit, name in enumerate(_BYTE2_BUTTONS) if raw[2] >> bit & 1}
    held |= {name for bit, name in enumerate(_BYTE3_BUTTONS) if raw[3] >> bit & 1}
    lx, rx, ry = struct.unpack_from("<3f", raw, 4)
    (ly,) = struct.unpack_from("<f", raw, 20)
    lx, ly, rx, ry = (float(np.clip(v, -1.0, 1.0)) if np.isfinite(v) else 0.0 for v in (lx, ly, rx, ry))
    return WirelessRemote(lx, ly, rx, ry, buttons=frozenset(held))


def encode_wireless_remote(remote: WirelessRemote) -> bytes:
    """The inverse of `decode_wireless_remote` (what the simulated robot publishes)."""
    raw = bytearray(40)
    raw[2] = sum(1 << bit for bit, name in enumerate(_BYTE2_BUTTONS) if name in remote.buttons)
    raw[3] = sum(1 << bit for bit, name in enumerate(_BYTE3_BUTTONS) if name in remote.buttons)
    struct.pack_into("<3f", raw, 4, remote.lx, remote.rx, remote.ry)
    struct.pack_into("<f", raw, 20, remote.ly)
    return bytes(raw)


def low_cmd_fields(record: np.ndarray) -> dict[str, Any]:
    """A `LowCmd_` record as plain data: the header, the CRC, and every motor slot that is not all zero."""
    motors = {}
    for i, slot in enumerate(record["motor_cmd"]):
        values = {k: float(slot[k]) for k in ("q", "dq", "tau", "kp", "kd")}
        if int(slot["mode"]) or any(values.values()):
            motors[str(i)] = {"mode": int(slot["mode"]), **values}
    return {"kind": "LowCmd_", "mode_pr": int(record["mode_pr"]), "mode_machine": int(record["mode_machine"]),
            "crc": f"{int(record['crc']):#010x}", "motors": motors}  # fmt: skip


def low_state_fields(record: np.ndarray) -> dict[str, Any]:
    """A `LowState_` record as plain data: header, IMU, the 29 joints' states, the remote."""
    imu = record["imu_state"]
    joints = [
        {"q": float(m["q"]), "dq": float(m["dq"]), "tau_est": float(m["tau_est"]), "temperature": [int(t) for t in m["temperature"]],
         "vol": float(m["vol"]), "motorstate": int(m["motorstate"])}
        for m in record["motor_state"][:NUM_JOINTS]
    ]  # fmt: skip
    remote = decode_wireless_remote(record["wireless_remote"])
    return {
        "kind": "LowState_", "version": [int(v) for v in record["version"]], "mode_pr": int(record["mode_pr"]),
        "mode_machine": int(record["mode_machine"]), "tick": int(record["tick"]), "crc": f"{int(record['crc']):#010x}",
        "imu": {k: [float(v) for v in imu[k]] for k in ("quaternion", "gyroscope", "accelerometer", "rpy")}
        | {"temperature": int(imu["temperature"])},
        "joints": joints,
        "wireless_remote": {"lx": remote.lx, "ly": remote.ly, "rx": remote.rx, "ry": remote.ry, "buttons": sorted(remote.buttons)},
    }  # fmt: skip
