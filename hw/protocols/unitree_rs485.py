"""Unitree GO-M8010-style RS-485 motor frames (little-endian).

Command, 17 bytes: header FE EE; byte 2 = motor id (bits 0-3) | mode (bits 4-6: 0 brake,
1 FOC, 2 calibrate); int16 torque = tau * 256; int16 speed = dq * 256 / (2 pi);
int32 position = q * 32768 / (2 pi); uint16 kp = kp * 1280; uint16 kd = kd * 1280; each
truncated toward zero after clamping to its field's range; CRC-16/KERMIT over bytes 0-14
in bytes 15-16. Reply, 16 bytes: header FD EE, id/mode byte, torque, speed, position with
the same scales, int8 temperature, uint16 whose bits 0-2 are the error code, CRC over
bytes 0-13 in bytes 14-15. All quantities are on the rotor side; the joint map's gear ratio
converts (`hw.jointmap.motor_to_joint` and its inverse).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from hw.protocols.command import MotorCommand
from hw.protocols.crc import CrcError, FrameError, check_crc_frame, crc16_kermit

__all__ = ["CrcError", "FrameError"]  # re-exported: callers catch them from here

COMMAND_HEADER = b"\xfe\xee"
REPLY_HEADER = b"\xfd\xee"
COMMAND_SIZE = 17
REPLY_SIZE = 16
MODE_BRAKE, MODE_FOC, MODE_CALIBRATE = 0, 1, 2
GO_M8010_GEAR_RATIO = 6.33

ERRORS = {0: "ok", 1: "overheat", 2: "overcurrent", 3: "overvoltage", 4: "encoder fault"}

_TORQUE_SCALE = 256.0
_SPEED_SCALE = 256.0 / (2.0 * math.pi)
_POSITION_SCALE = 32768.0 / (2.0 * math.pi)
_GAIN_SCALE = 1280.0
_CMD = struct.Struct("<2sBhhiHH")
_REPLY = struct.Struct("<2sBhhibH")


@dataclass(frozen=True)
class CommandFrame:
    """What one command frame carries: the motor it addresses, its mode and the PD command."""

    motor_id: int
    mode: int
    command: MotorCommand


@dataclass(frozen=True)
class MotorReply:
    motor_id: int
    mode: int
    torque: float
    speed: float
    position: float
    temperature: int
    error_code: int

    @property
    def error(self) -> str:
        return ERRORS.get(self.error_code, f"unknown error {self.error_code}")


def _fixed(x: float, scale: float, lo: int, hi: int) -> int:
    """Scale, clamp to the field's range and truncate toward zero."""
    return int(min(max(x * scale, lo), hi))


def _id_mode(motor_id: int, mode: int) -> int:
    if not 0 <= motor_id <= 15:
        raise ValueError(f"RS-485 motor id must be 0-15, got {motor_id}")
    if not 0 <= mode <= 7:
        raise ValueError(f"RS-485 mode must be 0-7, got {mode}")
    return (motor_id & 0x0F) | (mode << 4)


def encode_command(motor_id: int, mode: int, torque: float, speed: float, position: float, kp: float, kd: float) -> bytes:
    body = _CMD.pack(
        COMMAND_HEADER,
        _id_mode(motor_id, mode),
        _fixed(torque, _TORQUE_SCALE, -32768, 32767),
        _fixed(speed, _SPEED_SCALE, -32768, 32767),
        _fixed(position, _POSITION_SCALE, -(2**31), 2**31 - 1),
        _fixed(kp, _GAIN_SCALE, 0, 65535),
        _fixed(kd, _GAIN_SCALE, 0, 65535),
    )
    return body + struct.pack("<H", crc16_kermit(body))


def decode_command(frame: bytes) -> CommandFrame:
    check_crc_frame(frame, COMMAND_SIZE, COMMAND_HEADER, "RS-485 command")
    _, id_mode, tau, dq, q, kp, kd = _CMD.unpack_from(frame)
    command = MotorCommand(
        position=q / _POSITION_SCALE, velocity=dq / _SPEED_SCALE, kp=kp / _GAIN_SCALE, kd=kd / _GAIN_SCALE, torque=tau / _TORQUE_SCALE
    )
    return CommandFrame(id_mode & 0x0F, (id_mode >> 4) & 0x07, command)


def encode_reply(motor_id: int, mode: int, torque: float, speed: float, position: float, temperature: int, error_code: int = 0) -> bytes:
    body = _REPLY.pack(
        REPLY_HEADER,
        _id_mode(motor_id, mode),
        _fixed(torque, _TORQUE_SCALE, -32768, 32767),
        _fixed(speed, _SPEED_SCALE, -32768, 32767),
        _fixed(position, _POSITION_SCALE, -(2**31), 2**31 - 1),
        int(min(max(temperature, -128), 127)),
        error_code & 0x7,
    )
    return body + struct.pack("<H", crc16_kermit(body))


def decode_reply(frame: bytes) -> MotorReply:
    check_crc_frame(frame, REPLY_SIZE, REPLY_HEADER, "RS-485 reply")
    _, id_mode, tau, dq, q, temp, err = _REPLY.unpack_from(frame)
    return MotorReply(id_mode & 0x0F, (id_mode >> 4) & 0x07, tau / _TORQUE_SCALE, dq / _SPEED_SCALE, q / _POSITION_SCALE, temp, err & 0x7)


class FrameSplitter:
    """Cuts fixed-size frames with a known header out of a byte stream, resyncing after garbage."""

    def __init__(self, header: bytes, size: int) -> None:
        self.header = header
        self.size = size
        self._buf = bytearray()
        self.discarded_bytes = 0

    def feed(self, data: bytes) -> list[bytes]:
        self._buf += data
        frames: list[bytes] = []
        while True:
            start = self._buf.find(self.header)
            if start < 0:
                keep = 1 if self._buf[-1:] == self.header[:1] else 0
                self.discarded_bytes += len(self._buf) - keep
                del self._buf[: len(self._buf) - keep]
                return frames
            if start:
                self.discarded_bytes += start
                del self._buf[:start]
            if len(self._buf) < self.size:
                return frames
            frames.append(bytes(self._buf[: self.size]))
            del self._buf[: self.size]
