"""MIT-mode CAN frames of CubeMars AK and Damiao DM actuators.

Command (8 bytes, big-endian bit fields): position 16 bits, velocity 12, kp 12, kd 12,
torque 12 — position in bytes 0-1; velocity in byte 2 and the high nibble of byte 3; kp
in the low nibble of byte 3 and byte 4; kd in byte 5 and the high nibble of byte 6;
torque in the low nibble of byte 6 and byte 7. Each value is clamped to its model's
range by the host (the firmware does not clamp) and scaled
`uint = int((x - min) * ((1 << bits) - 1) / (max - min))`.

Replies: the 6-byte form (id, position 16, velocity 12, torque 12), CubeMars' 8-byte
form adding temperature (int8, deg C) and an error code, and Damiao's 8-byte form with
the error in the high nibble of byte 0 and MOSFET and rotor temperatures in bytes 6-7.
Sources: CubeMars AK series product manual (MIT mode), Damiao DM-J4310-2EC manual.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from hw.protocols.command import MotorCommand

ENTER_MOTOR_MODE = bytes.fromhex("fffffffffffffffc")
EXIT_MOTOR_MODE = bytes.fromhex("fffffffffffffffd")
SET_ZERO = bytes.fromhex("fffffffffffffffe")
SPECIAL_FRAMES = {ENTER_MOTOR_MODE: "enter", EXIT_MOTOR_MODE: "exit", SET_ZERO: "zero"}

ReplyVariant = Literal["basic", "cubemars", "damiao"]
REPLY_VARIANTS: tuple[str, ...] = ("basic", "cubemars", "damiao")

CUBEMARS_ERRORS = {
    0: "ok",
    1: "motor over-temperature",
    2: "over-current",
    3: "over-voltage",
    4: "under-voltage",
    5: "encoder fault",
    6: "MOSFET over-temperature",
    7: "motor stall",
}
DAMIAO_STATES = {
    0x0: "disabled",
    0x1: "ok",  # enabled
    0x8: "over-voltage",
    0x9: "under-voltage",
    0xA: "over-current",
    0xB: "MOSFET over-temperature",
    0xC: "coil over-temperature",
    0xD: "communication lost",
    0xE: "overload",
}
DAMIAO_HEALTHY = (0x0, 0x1)


@dataclass(frozen=True)
class MitRanges:
    """Symmetric position/velocity/torque ranges and gain ranges of one motor model.

    Values per model live in `configs/motors.yaml`, with their sources.
    """

    p_max: float
    v_max: float
    t_max: float
    kp_max: float = 500.0
    kd_max: float = 5.0


@dataclass(frozen=True)
class MitReply:
    motor_id: int
    position: float
    velocity: float
    torque: float
    temperature: float | None = None  # deg C (CubeMars: motor; Damiao: rotor)
    mosfet_temperature: float | None = None  # deg C (Damiao)
    error_code: int = 0
    error: str = "ok"

    @property
    def faulted(self) -> bool:
        return self.error not in ("ok", "disabled")


def float_to_uint(x: float, lo: float, hi: float, bits: int) -> int:
    """Clamp `x` to [lo, hi] and scale it to an unsigned `bits`-bit integer (truncating)."""
    x = min(max(x, lo), hi)
    return int((x - lo) * ((1 << bits) - 1) / (hi - lo))


def uint_to_float(u: int, lo: float, hi: float, bits: int) -> float:
    return u * (hi - lo) / ((1 << bits) - 1) + lo


def encode_command(r: MitRanges, position: float, velocity: float, kp: float, kd: float, torque: float) -> bytes:
    # `float_to_uint` written out for each field: this runs for every motor at 500 Hz.
    pm, vm, tm = r.p_max, r.v_max, r.t_max
    p = int((min(max(position, -pm), pm) + pm) * 65535 / (2 * pm))
    v = int((min(max(velocity, -vm), vm) + vm) * 4095 / (2 * vm))
    kp_u = int(min(max(kp, 0.0), r.kp_max) * 4095 / r.kp_max)
    kd_u = int(min(max(kd, 0.0), r.kd_max) * 4095 / r.kd_max)
    t = int((min(max(torque, -tm), tm) + tm) * 4095 / (2 * tm))
    return bytes(
        (p >> 8, p & 0xFF, v >> 4, ((v & 0xF) << 4) | (kp_u >> 8), kp_u & 0xFF, kd_u >> 4, ((kd_u & 0xF) << 4) | (t >> 8), t & 0xFF)
    )


def decode_command(r: MitRanges, data: bytes) -> MotorCommand:
    """The firmware's side: the command values an 8-byte frame carries."""
    if len(data) != 8:
        raise ValueError(f"MIT command must be 8 bytes, got {len(data)}")
    p = (data[0] << 8) | data[1]
    v = (data[2] << 4) | (data[3] >> 4)
    kp_u = ((data[3] & 0xF) << 8) | data[4]
    kd_u = (data[5] << 4) | (data[6] >> 4)
    t = ((data[6] & 0xF) << 8) | data[7]
    return MotorCommand(
        position=uint_to_float(p, -r.p_max, r.p_max, 16),
        velocity=uint_to_float(v, -r.v_max, r.v_max, 12),
        kp=uint_to_float(kp_u, 0.0, r.kp_max, 12),
        kd=uint_to_float(kd_u, 0.0, r.kd_max, 12),
        torque=uint_to_float(t, -r.t_max, r.t_max, 12),
    )


def encode_reply(
    r: MitRanges,
    variant: ReplyVariant,
    motor_id: int,
    position: float,
    velocity: float,
    torque: float,
    temperature: float = 25.0,
    mosfet_temperature: float = 25.0,
    error_code: int = 0,
) -> bytes:
    """The firmware's side: a status reply in the given variant."""
    p = float_to_uint(position, -r.p_max, r.p_max, 16)
    v = float_to_uint(velocity, -r.v_max, r.v_max, 12)
    t = float_to_uint(torque, -r.t_max, r.t_max, 12)
    first = (motor_id & 0x0F) | ((error_code & 0x0F) << 4) if variant == "damiao" else motor_id & 0xFF
    body = bytes((first, p >> 8, p & 0xFF, v >> 4, ((v & 0xF) << 4) | (t >> 8), t & 0xFF))
    if variant == "basic":
        return body
    if variant == "cubemars":
        return body + bytes((int(max(-128, min(127, temperature))) & 0xFF, error_code & 0xFF))
    return body + bytes((int(max(0, min(255, mosfet_temperature))), int(max(0, min(255, temperature)))))


def reply_scales(r: MitRanges) -> tuple[float, float, float, float, float, float]:
    """(span, max) for position, velocity and torque of a model's replies, computed once per motor."""
    return 2 * r.p_max, r.p_max, 2 * r.v_max, r.v_max, 2 * r.t_max, r.t_max


def reply_values(word: int, scales: tuple[float, float, float, float, float, float]) -> tuple[float, float, float]:
    """Position, velocity and torque of a reply read as a big-endian 64-bit word (a 6-byte
    reply padded with zeros): bytes 1-5 have the same layout in every variant. `scales` from
    `reply_scales`; it runs for every reply at 500 Hz.

    Each value is read at the middle of its quantisation step: the firmware truncates
    (`float_to_uint`), so the lower edge that `uint_to_float` gives is half a step low on
    average. A velocity half a step low on every joint (0.01 rad/s with a 40 rad/s range)
    made the state estimator's leg odometry drift 2.7 % of the distance walked, against
    0.25 % with the true velocities.
    """
    sp, pm, sv, vm, st, tm = scales
    return (
        (((word >> 40) & 0xFFFF) + 0.5) * sp / 65535 - pm,
        (((word >> 28) & 0xFFF) + 0.5) * sv / 4095 - vm,
        (((word >> 16) & 0xFFF) + 0.5) * st / 4095 - tm,
    )


def decode_reply(r: MitRanges, variant: ReplyVariant, data: bytes) -> MitReply:
    """Decode a status reply; a frame of the wrong length raises `ValueError`."""
    expected = 6 if variant == "basic" else 8
    if len(data) != expected:
        raise ValueError(f"MIT {variant} reply must be {expected} bytes, got {len(data)}")
    position, velocity, torque = reply_values(int.from_bytes(data.ljust(8, b"\0"), "big"), reply_scales(r))
    if variant == "basic":
        return MitReply(data[0], position, velocity, torque)
    if variant == "cubemars":
        temp = data[6] - 256 if data[6] > 127 else data[6]
        code = data[7]
        return MitReply(data[0], position, velocity, torque, float(temp), None, code, CUBEMARS_ERRORS.get(code, f"unknown error {code}"))
    code = data[0] >> 4
    state = DAMIAO_STATES.get(code, f"unknown state {code:#x}")
    return MitReply(data[0] & 0x0F, position, velocity, torque, float(data[7]), float(data[6]), code, state)


def encode_commands(
    r: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    position: np.ndarray,
    velocity: np.ndarray,
    kp: np.ndarray,
    kd: np.ndarray,
    torque: np.ndarray,
) -> np.ndarray:
    """`encode_command` for many motors at once: ranges and values are arrays, one entry per
    motor (`r` = p_max, v_max, t_max, kp_max, kd_max). Returns an [n, 8] uint8 array whose
    rows are byte-identical to `encode_command` (same operations in the same order)."""
    pm, vm, tm, kpm, kdm = r
    p = ((np.minimum(np.maximum(position, -pm), pm) + pm) * 65535 / (2 * pm)).astype(np.int64)
    v = ((np.minimum(np.maximum(velocity, -vm), vm) + vm) * 4095 / (2 * vm)).astype(np.int64)
    kp_u = (np.minimum(np.maximum(kp, 0.0), kpm) * 4095 / kpm).astype(np.int64)
    kd_u = (np.minimum(np.maximum(kd, 0.0), kdm) * 4095 / kdm).astype(np.int64)
    t = ((np.minimum(np.maximum(torque, -tm), tm) + tm) * 4095 / (2 * tm)).astype(np.int64)
    out = np.empty((len(p), 8), dtype=np.uint8)
    out[:, 0] = p >> 8
    out[:, 1] = p & 0xFF
    out[:, 2] = v >> 4
    out[:, 3] = ((v & 0xF) << 4) | (kp_u >> 8)
    out[:, 4] = kp_u & 0xFF
    out[:, 5] = kd_u >> 4
    out[:, 6] = ((kd_u & 0xF) << 4) | (t >> 8)
    out[:, 7] = t & 0xFF
    return out
