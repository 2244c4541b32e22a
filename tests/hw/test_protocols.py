"""Golden bytes for every frame codec, worked out by hand from the protocol layouts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hw.protocols import imu, mit
from hw.protocols import unitree_rs485 as rs485
from hw.protocols.crc import crc16_kermit

AK80_9 = mit.MitRanges(p_max=12.5, v_max=50.0, t_max=18.0, kp_max=500.0, kd_max=5.0)
DM4310 = mit.MitRanges(p_max=12.5, v_max=30.0, t_max=10.0, kp_max=500.0, kd_max=5.0)


def test_crc16_kermit_check_value() -> None:
    assert crc16_kermit(b"123456789") == 0x2189
    assert crc16_kermit(b"") == 0


def test_mit_special_frames() -> None:
    assert mit.ENTER_MOTOR_MODE.hex() == "fffffffffffffffc"
    assert mit.EXIT_MOTOR_MODE.hex() == "fffffffffffffffd"
    assert mit.SET_ZERO.hex() == "fffffffffffffffe"


def test_mit_zero_command() -> None:
    # p: 12.5 * 65535 / 25 = 32767.5 -> 0x7fff; v, t: 2047.5 -> 0x7ff; kp, kd: 0.
    assert mit.encode_command(AK80_9, 0.0, 0.0, 0.0, 0.0, 0.0).hex() == "7fff7ff0000007ff"


def test_mit_command_packs_fields_in_order() -> None:
    # p = 1.0   -> int(13.5 * 65535 / 25)   = 35388 = 0x8a3c
    # v = 2.0   -> int(52 * 4095 / 100)     = 2129  = 0x851
    # kp = 50   -> int(50 * 4095 / 500)     = 409   = 0x199
    # kd = 1.0  -> int(1 * 4095 / 5)        = 819   = 0x333
    # t = 3.0   -> int(21 * 4095 / 36)      = 2388  = 0x954
    assert mit.encode_command(AK80_9, 1.0, 2.0, 50.0, 1.0, 3.0).hex() == "8a3c851199333954"


def test_mit_command_clamps_on_the_host() -> None:
    # Everything past its range saturates: p 0xffff, v 0xfff, kp 0xfff, kd 0xfff, t 0x000.
    assert mit.encode_command(AK80_9, 99.0, 1e3, 1e4, 1e2, -1e3).hex() == "fffffffffffff000"
    assert mit.encode_command(DM4310, 0.0, -30.0, 0.0, 0.0, 10.0).hex() == "7fff000000000fff"


def test_mit_command_round_trip_within_quantization() -> None:
    frame = mit.encode_command(DM4310, -0.7, 3.3, 20.0, 0.5, -1.2)
    cmd = mit.decode_command(DM4310, frame)
    assert cmd.position == pytest.approx(-0.7, abs=25 / 65535)
    assert cmd.velocity == pytest.approx(3.3, abs=60 / 4095)
    assert cmd.kp == pytest.approx(20.0, abs=500 / 4095)
    assert cmd.kd == pytest.approx(0.5, abs=5 / 4095)
    assert cmd.torque == pytest.approx(-1.2, abs=20 / 4095)


def test_mit_basic_reply() -> None:
    # id 3; p 0x8000; v 0x800; t 0x7ff
    reply = mit.decode_reply(AK80_9, "basic", bytes.fromhex("0380008007ff"))
    assert reply.motor_id == 3
    assert reply.position == pytest.approx(32768.5 * 25 / 65535 - 12.5)  # the middle of the step
    assert reply.velocity == pytest.approx(0.0122 + 0.0122, abs=1e-3)  # 0x800 spans 0.012 to 0.037 rad/s
    assert reply.torque == pytest.approx(-0.0044 + 0.0044, abs=1e-3)
    assert reply.error == "ok"


def test_mit_cubemars_reply_temperature_and_error() -> None:
    frame = mit.encode_reply(AK80_9, "cubemars", 5, 0.0, 0.0, 0.0, temperature=-5, error_code=1)
    assert frame.hex() == "057fff7ff7fffb01"
    reply = mit.decode_reply(AK80_9, "cubemars", frame)
    assert reply.temperature == -5 and reply.error == "motor over-temperature" and reply.faulted


def test_mit_damiao_reply_state_nibble_and_temperatures() -> None:
    frame = bytes.fromhex("b17fff7ff7ff2d3c")  # state 0xB, id 1, MOS 45 C, rotor 60 C
    reply = mit.decode_reply(DM4310, "damiao", frame)
    assert reply.motor_id == 1 and reply.error == "MOSFET over-temperature" and reply.faulted
    assert reply.mosfet_temperature == 45 and reply.temperature == 60
    assert not mit.decode_reply(DM4310, "damiao", bytes.fromhex("117fff7ff7ff2d3c")).faulted
    assert mit.encode_reply(DM4310, "damiao", 1, 0.0, 0.0, 0.0, temperature=60, mosfet_temperature=45, error_code=0xB) == frame


@pytest.mark.parametrize("variant,size", [("basic", 5), ("cubemars", 6), ("damiao", 7)])
def test_mit_reply_wrong_length(variant: mit.ReplyVariant, size: int) -> None:
    with pytest.raises(ValueError, match="bytes, got"):
        mit.decode_reply(AK80_9, variant, bytes(size))


def test_rs485_command_golden() -> None:
    # id 1 | FOC << 4 = 0x11; tau 0.5 -> 128; dq 1.0 -> int(40.74) = 40; q 0.1 -> int(521.5) = 521;
    # kp 0.2 -> 256; kd 0.05 -> 64.
    frame = rs485.encode_command(1, rs485.MODE_FOC, 0.5, 1.0, 0.1, 0.2, 0.05)
    body = bytes.fromhex("feee11800028000902000000014000")
    assert frame[:15] == body
    assert frame[15:] == crc16_kermit(body).to_bytes(2, "little")
    assert len(frame) == 17


def test_rs485_negative_values_truncate_toward_zero_and_clamp() -> None:
    frame = rs485.encode_command(15, rs485.MODE_BRAKE, -0.999 / 256, -1e9, -math.pi, 100.0, -1.0)
    decoded = rs485.decode_command(frame)
    assert (decoded.motor_id, decoded.mode) == (15, rs485.MODE_BRAKE)
    assert frame[2] == 0x0F
    assert frame[3:5] == b"\x00\x00"  # -0.999 truncates to 0
    assert frame[5:7] == (-32768).to_bytes(2, "little", signed=True)
    assert frame[7:11] == (-16384).to_bytes(4, "little", signed=True)
    assert frame[11:13] == b"\xff\xff" and frame[13:15] == b"\x00\x00"
    assert decoded.command.position == pytest.approx(-math.pi)


def test_rs485_reply_round_trip_and_error_bits() -> None:
    frame = rs485.encode_reply(2, rs485.MODE_FOC, -1.5, 20.0, 3.0, 41, error_code=2)
    assert frame[:3] == bytes.fromhex("fdee12") and len(frame) == 16
    reply = rs485.decode_reply(frame)
    assert (reply.motor_id, reply.mode, reply.temperature, reply.error) == (2, 1, 41, "overcurrent")
    assert reply.torque == -1.5
    assert reply.speed == pytest.approx(20.0, abs=2 * math.pi / 256)
    assert reply.position == pytest.approx(3.0, abs=2 * math.pi / 32768)


def test_rs485_bad_crc_length_and_header() -> None:
    frame = bytearray(rs485.encode_reply(2, 1, 0.0, 0.0, 0.0, 30))
    frame[5] ^= 0x01
    with pytest.raises(rs485.CrcError, match="CRC mismatch"):
        rs485.decode_reply(bytes(frame))
    for malformed, what in ((bytes(frame[:15]), "16 bytes, got 15"), (b"\xfe\xee" + bytes(frame[2:]), "header")):
        with pytest.raises(rs485.FrameError, match=what) as caught:
            rs485.decode_reply(malformed)
        assert not isinstance(caught.value, rs485.CrcError)  # counted as a bad frame, not a CRC error


def test_gear_ratio_and_direction_conversions() -> None:
    from hw.jointmap import JointConfig, joint_to_motor, motor_to_joint

    joint = JointConfig(
        bus="b",
        protocol="unitree-rs485",
        id=1,
        position_limits=(-1.0, 1.0),
        velocity_limit=10.0,
        torque_limit=50.0,
        direction=-1,
        zero_offset=0.2,
        gear_ratio=6.33,
    )
    q, dq, tau = motor_to_joint(joint, -6.33, 12.66, 1.0)
    assert (q, dq, tau) == pytest.approx((1.2, -2.0, -6.33))
    assert joint_to_motor(joint, q, dq, tau) == pytest.approx((-6.33, 12.66, 1.0))


def test_frame_splitter_resyncs_after_garbage() -> None:
    a = rs485.encode_reply(1, 1, 0.0, 0.0, 0.0, 30)
    b = rs485.encode_reply(2, 1, 0.0, 0.0, 0.0, 30)
    splitter = rs485.FrameSplitter(rs485.REPLY_HEADER, rs485.REPLY_SIZE)
    assert splitter.feed(b"\x00\x01" + a[:7]) == []
    assert splitter.feed(a[7:] + b"\xfd") == [a]
    assert splitter.feed(b[1:]) == [b]
    assert splitter.discarded_bytes == 2


def test_imu_frame_round_trip_and_crc() -> None:
    sample = imu.ImuSample(65535, (1.0, 0.0, 0.0, 0.0), (0.1, -0.2, 0.3), (0.0, 0.0, 9.81))
    frame = imu.encode_imu(sample)
    assert len(frame) == imu.SIZE and frame[:5] == bytes.fromhex("a55a01ffff")
    back = imu.decode_imu(frame)
    assert back.sequence == 65535 and back.quaternion == (1.0, 0.0, 0.0, 0.0)
    assert back.angular_velocity == pytest.approx((0.1, -0.2, 0.3))
    broken = bytearray(frame)
    broken[30] ^= 0xFF
    with pytest.raises(rs485.CrcError, match="CRC"):
        imu.decode_imu(bytes(broken))


def test_batch_mit_encode_matches_the_scalar_function() -> None:
    import numpy as np

    rng = np.random.default_rng(0)
    n = 2000
    models = [AK80_9, DM4310]
    which = rng.integers(0, 2, n)
    ranges = tuple(np.array([getattr(models[w], f) for w in which]) for f in ("p_max", "v_max", "t_max", "kp_max", "kd_max"))
    values = [rng.uniform(-60, 600, n) for _ in range(5)]
    batch = mit.encode_commands(ranges, *values)  # type: ignore[arg-type]
    for i in range(n):
        scalar = mit.encode_command(models[which[i]], *(float(v[i]) for v in values))
        assert batch[i].tobytes() == scalar


def test_reply_values_are_the_middle_of_the_truncated_step() -> None:
    frame = mit.encode_reply(AK80_9, "cubemars", 5, 1.2345, -7.5, 3.3)
    reply = mit.decode_reply(AK80_9, "cubemars", frame)
    p, v, t = (frame[1] << 8) | frame[2], (frame[3] << 4) | (frame[4] >> 4), ((frame[4] & 0xF) << 8) | frame[5]
    assert reply.position == pytest.approx(mit.uint_to_float(p, -12.5, 12.5, 16) + 0.5 * 25 / 65535, abs=1e-12)
    assert reply.velocity == pytest.approx(mit.uint_to_float(v, -50.0, 50.0, 12) + 0.5 * 100 / 4095, abs=1e-12)
    assert reply.torque == pytest.approx(mit.uint_to_float(t, -18.0, 18.0, 12) + 0.5 * 36 / 4095, abs=1e-12)


def test_reply_velocities_are_unbiased() -> None:
    """The firmware truncates: read at the lower edge, every velocity is half a step low on average; at the middle, not."""
    rng = np.random.default_rng(0)
    velocities = rng.uniform(-3.0, 3.0, 4000)
    read = np.array([mit.decode_reply(AK80_9, "basic", mit.encode_reply(AK80_9, "basic", 1, 0.0, v, 0.0)).velocity for v in velocities])
    step = 100 / 4095
    assert abs(float(np.mean(read - velocities))) < 0.05 * step
    assert np.max(np.abs(read - velocities)) <= 0.5 * step + 1e-12
