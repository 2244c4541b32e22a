"""The project's serial IMU frame (47 bytes, little-endian).

    offset  size  field
    0       2     header A5 5A
    2       1     frame type, 0x01 = attitude + rates + acceleration
    3       2     uint16 sequence number (wraps)
    5       16    float32 quaternion w, x, y, z (IMU frame in world, unit norm)
    21      12    float32 angular velocity x, y, z (rad/s, IMU frame)
    33      12    float32 linear acceleration x, y, z (m/s^2, IMU frame, gravity included)
    45      2     CRC-16/KERMIT over bytes 0-44

A fixed size, a two-byte header and a CRC make it easy to resynchronise on a serial
stream; sequence numbers expose dropped frames. No widespread IMU protocol carries
exactly this set in one frame without vendor-specific configuration, so the stack
defines its own and an adapter per real IMU converts into `ImuSample`.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from hw.protocols.crc import FrameError, check_crc_frame, crc16_kermit

HEADER = b"\xa5\x5a"
FRAME_TYPE = 0x01
SIZE = 47
_BODY = struct.Struct("<2sBH4f3f3f")


@dataclass(frozen=True)
class ImuSample:
    sequence: int
    quaternion: tuple[float, float, float, float]
    angular_velocity: tuple[float, float, float]
    linear_acceleration: tuple[float, float, float]


def encode_imu(sample: ImuSample) -> bytes:
    body = _BODY.pack(
        HEADER, FRAME_TYPE, sample.sequence & 0xFFFF, *sample.quaternion, *sample.angular_velocity, *sample.linear_acceleration
    )
    return body + struct.pack("<H", crc16_kermit(body))


def decode_imu(frame: bytes) -> ImuSample:
    check_crc_frame(frame, SIZE, HEADER, "IMU frame")
    _, kind, seq, *values = _BODY.unpack_from(frame)
    if kind != FRAME_TYPE:
        raise FrameError(f"IMU frame type {kind:#04x} is not {FRAME_TYPE:#04x}")
    q, w, a = values[0:4], values[4:7], values[7:10]
    return ImuSample(seq, (q[0], q[1], q[2], q[3]), (w[0], w[1], w[2]), (a[0], a[1], a[2]))
