"""The G1's messages on Cyclone DDS (the `g1` extra): CDR round trips keep every field and the CRC, and a loopback exchange."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")

from hw.dds import cdr
from hw.dds import messages as m
from hw.dds.session import DdsConfig, DdsSession, domain_xml
from hw.errors import ConfigError
from hw.protocols import unitree_hg as hg
from hw.protocols.crc import FrameError
from tests.conftest import HANG_S, wait_for


def a_low_state() -> np.ndarray:
    record = np.zeros((), dtype=hg.LOW_STATE)
    record["mode_machine"], record["tick"] = 5, 777
    record["imu_state"]["quaternion"] = (1.0, 0.0, 0.0, 0.0)
    record["motor_state"]["q"][:29] = np.linspace(-1.0, 1.0, 29)
    record["motor_state"]["temperature"][3] = (40, 35)
    record["wireless_remote"] = np.frombuffer(hg.encode_wireless_remote(hg.WirelessRemote(ly=0.5, buttons=frozenset({"A"}))), np.uint8)
    return hg.with_crc(record)


def test_cdr_round_trips_keep_every_field_and_the_crc() -> None:
    command = hg.unpack_low_cmd(hg.encode_motor_command(3, 1, 0.25, -1.0, 0.5, 60.0, 1.5, mode_machine=5))
    back = m.low_cmd_to_record(m.LowCmd_.deserialize(m.low_cmd_from_record(command).serialize()))
    assert hg.canonical(back).tobytes() == hg.canonical(command).tobytes() and hg.crc_ok(back)
    state = a_low_state()
    received = m.low_state_to_record(m.LowState_.deserialize(m.low_state_from_record(state).serialize()))
    assert received.tobytes() == state.tobytes() and hg.crc_ok(received)
    received["motor_state"]["q"][0] += 0.01  # a changed field no longer matches its CRC
    assert not hg.crc_ok(received)


def test_records_pack_the_same_whatever_numpy_left_in_their_padding() -> None:
    state = a_low_state()
    assert hg.pack(state.copy()) == hg.pack(state)  # numpy's copies leave padding uninitialized; packing zeroes it


def test_config_mistakes_are_named() -> None:
    with pytest.raises(ConfigError, match="domain must be 0..232"):
        DdsConfig(domain=300)
    assert '<NetworkInterface name="eth0"/>' in domain_xml(DdsConfig(domain=0, interface="eth0", peers=()))


def test_a_low_cmd_crosses_loopback_dds(claim_dds_domain: Callable[[], int]) -> None:
    session = DdsSession(DdsConfig(domain=claim_dds_domain(), interface="lo"))
    try:
        writer = session.writer("rt/lowcmd", m.LowCmd_)
        reader = session.reader("rt/lowcmd", m.LowCmd_)
        command = hg.unpack_low_cmd(hg.encode_motor_command(0, 1, 0.1, 0.0, 0.0, 40.0, 1.0, mode_machine=2))
        received = []

        def came_back() -> bool:  # written until discovery is done
            nonlocal received
            writer.write(m.low_cmd_from_record(command))
            received = reader.take(N=1)
            return bool(received)

        assert wait_for(came_back), f"no LowCmd_ came back over loopback in {HANG_S} s"
        record = m.low_cmd_to_record(received[0])
        assert hg.crc_ok(record) and int(record["mode_machine"]) == 2 and float(record["motor_cmd"][0]["kp"]) == 40.0
    finally:
        session.close()


def random_records(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    command = hg.new_low_cmd(mode_pr=1, mode_machine=int(rng.integers(0, 256)))
    motors = command["motor_cmd"]
    motors["mode"] = rng.integers(0, 256, 35)
    for name in ("q", "dq", "tau", "kp", "kd"):
        motors[name] = rng.normal(size=35)
    motors["reserve"] = rng.integers(0, 2**32, 35, dtype=np.uint64)
    command["reserve"] = rng.integers(0, 2**32, 4, dtype=np.uint64)
    state = a_low_state()
    state["version"], state["tick"] = rng.integers(0, 2**32, 2, dtype=np.uint64), int(rng.integers(0, 2**32))
    for name in ("quaternion", "gyroscope", "accelerometer", "rpy"):
        state["imu_state"][name] = rng.normal(size=state["imu_state"][name].shape)
    state["imu_state"]["temperature"] = -7
    ms = state["motor_state"]
    ms["mode"] = rng.integers(0, 256, 35)
    for name in ("q", "dq", "ddq", "tau_est", "vol"):
        ms[name] = rng.normal(size=35)
    ms["temperature"] = rng.integers(-100, 100, (35, 2))
    ms["sensor"] = rng.integers(0, 2**32, (35, 2), dtype=np.uint64)
    ms["motorstate"] = rng.integers(0, 2**32, 35, dtype=np.uint64)
    ms["reserve"] = rng.integers(0, 2**32, (35, 4), dtype=np.uint64)
    state["wireless_remote"] = rng.integers(0, 256, 40)
    return hg.with_crc(command), hg.with_crc(state)


@pytest.mark.parametrize("seed", range(5))
def test_the_numpy_cdr_is_byte_for_byte_cyclone_ddss(seed: int) -> None:
    command, state = random_records(seed)
    assert cdr.low_cmd_to_cdr(command) == m.low_cmd_from_record(command).serialize()  # 1004 bytes
    assert cdr.low_state_to_cdr(state) == m.low_state_from_record(state).serialize()  # 2092 bytes
    assert hg.canonical(cdr.low_cmd_from_cdr(cdr.low_cmd_to_cdr(command))).tobytes() == hg.canonical(command).tobytes()
    assert hg.canonical(cdr.low_state_from_cdr(cdr.low_state_to_cdr(state))).tobytes() == hg.canonical(state).tobytes()
    decoded = cdr.low_state_from_cdr(cdr.low_state_to_cdr(state))
    assert decoded.tobytes() == hg.canonical(state).tobytes() and hg.crc_ok(decoded, padding_zero=True)  # padding decoded as zero
    assert cdr.low_cmd_to_cdr(command)[4 + 2] == command["motor_cmd"]["mode"][0]  # the first mode right after the header bytes


def test_a_short_or_big_endian_sample_is_refused() -> None:
    command, _ = random_records(0)
    data = cdr.low_cmd_to_cdr(command)
    with pytest.raises(FrameError, match="LowCmd_ CDR must be 1004 bytes, got 1000"):
        cdr.low_cmd_from_cdr(data[:1000])
    with pytest.raises(FrameError, match="not plain little-endian CDR"):
        cdr.low_cmd_from_cdr(b"\x00\x00\x00\x00" + data[4:])


def test_the_cdr_crc_and_health_read_in_place_agree_with_the_record() -> None:
    rng = np.random.default_rng(3)
    for _ in range(50):  # any bytes at all, NaNs included: the CRC is over the packed words
        record = hg.with_crc(np.frombuffer(rng.bytes(hg.LOW_STATE_SIZE), np.uint8).copy().view(hg.LOW_STATE).reshape(()))
        data = cdr.low_state_to_cdr(record)
        assert cdr.low_state_crc_ok(data) and hg.crc_ok(record)
        broken = bytearray(data)
        broken[4 + 70] ^= 0x01  # motor 0's mode, the one byte whose word is split for the CRC
        assert not cdr.low_state_crc_ok(bytes(broken))
    state = a_low_state()
    state["motor_state"]["motorstate"][7], state["motor_state"]["temperature"][12] = 0x20, (91, 40)
    health = cdr.state_health(cdr.low_state_to_cdr(hg.with_crc(state)))
    assert health == (91, True)
    arrays = cdr.joint_arrays(cdr.low_state_to_cdr(hg.with_crc(state)))
    assert (
        arrays.motorstate[7] == 0x20 and tuple(arrays.temperature[12]) == (91, 40) and arrays.motion[5, 0] == state["motor_state"]["q"][5]
    )
