"""The G1's DDS messages: layouts, the CRC against a bit-by-bit transcription of Unitree's `crc32_core`, golden bytes, the remote."""

from __future__ import annotations

import importlib.util
import struct

import numpy as np
import pytest

from controller.commands.velocity import CommandLimits
from controller.inputs.unitree_remote import RemoteConfig, map_remote
from hw import dds
from hw.errors import ConfigError
from hw.protocols import unitree_hg as hg
from hw.protocols.crc import CrcError, FrameError, crc32_mpeg2, crc32_words


def crc32_core(words: list[int]) -> int:
    """Unitree's SDK algorithm, bit by bit as published: shift, xor the polynomial on a carry, xor it again on a data bit."""
    crc, poly = 0xFFFFFFFF, 0x04C11DB7
    for data in words:
        xbit = 1 << 31
        for _ in range(32):
            crc = ((crc << 1) & 0xFFFFFFFF) ^ poly if crc & 0x80000000 else (crc << 1) & 0xFFFFFFFF
            if data & xbit:
                crc ^= poly
            xbit >>= 1
    return crc


def test_crc_check_value_and_the_word_form_agree_with_the_sdks_algorithm() -> None:
    assert crc32_mpeg2(b"123456789") == 0x0376E6E7  # the catalogued check value of CRC-32/MPEG-2
    rng = np.random.default_rng(0)
    for n in (1, 7, 250):
        words = rng.integers(0, 2**32, n, dtype=np.uint64).tolist()
        big_endian = b"".join(struct.pack(">I", w) for w in words)
        assert crc32_words(words) == crc32_core(words) == crc32_mpeg2(big_endian)
    assert crc32_core([0] * 250) == 0xFE172F9F  # an all-zero LowCmd_ (worked out bit by bit)
    assert hg.pack(hg.new_low_cmd())[-4:] == struct.pack("<I", 0xFE172F9F)


def test_layouts_match_the_idl_with_natural_alignment() -> None:
    assert (hg.MOTOR_CMD.itemsize, hg.LOW_CMD.itemsize) == (28, 1004)
    assert (hg.IMU_STATE.itemsize, hg.MOTOR_STATE.itemsize, hg.LOW_STATE.itemsize) == (56, 56, 2092)
    offsets = {name: hg.LOW_STATE.fields[name][1] for name in ("mode_pr", "tick", "imu_state", "motor_state", "wireless_remote", "crc")}
    assert offsets == {"mode_pr": 8, "tick": 12, "imu_state": 16, "motor_state": 72, "wireless_remote": 2032, "crc": 2088}
    assert hg.LOW_CMD.fields["motor_cmd"][1] == 4 and hg.MOTOR_CMD.fields["q"][1] == 4 and hg.MOTOR_CMD.fields["reserve"][1] == 24


def test_golden_low_cmd_one_motor_set() -> None:
    frame = hg.encode_motor_command(3, 1, q=0.25, dq=-1.0, tau=0.5, kp=60.0, kd=1.5, mode_machine=5)
    assert len(frame) == 1004 and frame[:2] == b"\x00\x05"
    slot = 4 + 3 * 28
    assert frame[slot : slot + 28].hex() == "01000000" + "0000803e" + "000080bf" + "0000003f" + "00007042" + "0000c03f" + "00000000"
    assert frame[4:slot] == bytes(slot - 4) and frame[slot + 28 : 1000] == bytes(1000 - slot - 28)  # every other slot zero
    words = list(struct.unpack("<250I", frame[:1000]))
    assert frame[1000:] == struct.pack("<I", crc32_core(words)) == bytes.fromhex("62a619fc")
    fields = hg.low_cmd_fields(hg.unpack_low_cmd(frame))
    assert fields["mode_machine"] == 5 and fields["crc"] == "0xfc19a662"
    assert fields["motors"] == {"3": {"mode": 1, "q": 0.25, "dq": -1.0, "tau": 0.5, "kp": 60.0, "kd": 1.5}}


def test_a_damaged_or_short_message_is_refused() -> None:
    frame = bytearray(hg.encode_motor_command(0, 1, 0.1, 0.0, 0.0, 40.0, 1.0))
    frame[10] ^= 0x01
    with pytest.raises(CrcError, match="LowCmd_ CRC mismatch"):
        hg.unpack_low_cmd(frame)
    with pytest.raises(FrameError, match="must be 1004 bytes, got 1000"):
        hg.unpack_low_cmd(frame[:1000])
    with pytest.raises(FrameError, match="motor index must be 0..34"):
        hg.encode_motor_command(35, 1, 0.0, 0.0, 0.0, 0.0, 0.0)


def test_low_state_round_trip_with_the_remote() -> None:
    record = np.zeros((), dtype=hg.LOW_STATE)
    record["mode_machine"], record["tick"] = 7, 123456
    record["imu_state"]["quaternion"] = (1.0, 0.0, 0.0, 0.0)
    record["motor_state"]["q"][:29] = np.linspace(-1, 1, 29)
    record["motor_state"]["temperature"][4] = (41, 38)
    record["motor_state"]["motorstate"][12] = 0x4
    remote = hg.WirelessRemote(lx=0.5, ly=-0.25, rx=1.0, ry=0.0, buttons=frozenset({"start", "B", "L2"}))
    record["wireless_remote"] = np.frombuffer(hg.encode_wireless_remote(remote), dtype=np.uint8)
    data = hg.pack(record)
    fields = hg.low_state_fields(hg.unpack_low_state(data))
    assert len(data) == 2092 and fields["mode_machine"] == 7 and fields["tick"] == 123456
    assert fields["joints"][4]["temperature"] == [41, 38] and fields["joints"][12]["motorstate"] == 4
    assert fields["joints"][28]["q"] == pytest.approx(1.0) and len(fields["joints"]) == 29
    assert fields["wireless_remote"] == {"lx": 0.5, "ly": -0.25, "rx": 1.0, "ry": 0.0, "buttons": ["B", "L2", "start"]}


def test_remote_bytes_bit_by_bit() -> None:
    raw = bytearray(40)
    raw[2] = 0b0000_0100  # start (bit 2 of byte 2)
    raw[3] = 0b1000_0010  # B (bit 1) and left (bit 7)
    struct.pack_into("<f", raw, 4, -1.0)  # lx
    struct.pack_into("<f", raw, 20, 0.75)  # ly
    remote = hg.decode_wireless_remote(bytes(raw))
    assert remote.buttons == {"start", "B", "left"} and (remote.lx, remote.ly, remote.rx, remote.ry) == (-1.0, 0.75, 0.0, 0.0)
    assert hg.encode_wireless_remote(remote) == bytes(raw)
    struct.pack_into("<f", raw, 8, float("nan"))
    assert hg.decode_wireless_remote(bytes(raw)).rx == 0.0  # a garbled stick is no command
    with pytest.raises(FrameError, match="40 bytes"):
        hg.decode_wireless_remote(bytes(39))


def test_the_remote_drives_like_the_gamepad() -> None:
    limits, cfg = CommandLimits(vx=(-0.5, 0.8), vy=(-0.4, 0.4), yaw_rate=(-1.0, 1.0)), RemoteConfig()
    sample = map_remote(hg.WirelessRemote(lx=1.0, ly=1.0, rx=1.0, buttons=frozenset({"X"})), cfg, limits)
    assert (sample.velocity.vx, sample.velocity.vy, sample.velocity.yaw_rate) == (0.8, -0.4, -1.0)  # right is -vy, -yaw
    assert sample.alive and sample.gesture == "wave"
    still = map_remote(hg.WirelessRemote(lx=0.05, ly=-0.08, buttons=frozenset({"B", "start"})), cfg, limits)
    assert still.velocity.is_zero() and still.buttons.estop and still.buttons.start and not still.buttons.stop
    gone = map_remote(hg.WirelessRemote(ly=1.0), cfg, limits, age_s=1.0)
    assert not gone.alive and gone.velocity.is_zero()


def test_without_the_g1_extra_the_dds_backend_names_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *args: None)
    with pytest.raises(ConfigError, match=r"needs cyclonedds: pip install -e '\.\[g1\]'"):
        dds.require_cyclonedds()
