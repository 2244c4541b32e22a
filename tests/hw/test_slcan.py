"""slcan: the line codec pinned by golden bytes, and the host's python-can bus over a real pseudo-terminal."""

from __future__ import annotations

import os
import select
import tty
from collections.abc import Iterator

import can
import pytest
import serial

from hw.errors import BusError
from hw.jointmap import BusConfig
from hw.protocols import slcan
from hw.protocols.crc import FrameError
from hw.slcan import CAN_ERR_BUSOFF, CAN_ERR_CRTL, SlcanBus
from hw.transport import open_can


def test_frames_encode_to_their_lines() -> None:
    assert slcan.encode_frame(0x123, bytes.fromhex("deadbeef00112233")) == b"t1238DEADBEEF00112233\r"
    assert slcan.encode_frame(0x7, b"\x01\x02") == b"t00720102\r"
    assert slcan.encode_frame(0x123, bytes.fromhex("dead"), extended=True) == b"T000001232DEAD\r"
    assert slcan.encode_frame(0x5, b"") == b"t0050\r"
    assert slcan.open_commands(1_000_000) == b"C\rS8\rO\r" and slcan.open_commands(125_000) == b"C\rS4\rO\r"
    assert slcan.encode_status(slcan.STATUS_BUS_ERROR) == b"F80\r"
    with pytest.raises(ValueError, match="extended"):
        slcan.encode_frame(0x800, b"")
    with pytest.raises(ValueError, match="at most 8 bytes"):
        slcan.encode_frame(1, bytes(9))
    with pytest.raises(ValueError, match="no bitrate 300000"):
        slcan.open_commands(300_000)


def test_lines_decode_to_frames_and_malformed_ones_are_frame_errors() -> None:
    assert slcan.decode_frame(b"t1238DEADBEEF00112233") == slcan.SlcanFrame(0x123, bytes.fromhex("deadbeef00112233"))
    assert slcan.decode_frame(b"T000001232DEAD") == slcan.SlcanFrame(0x123, b"\xde\xad", extended=True)
    assert slcan.decode_frame(b"r1230") == slcan.SlcanFrame(0x123, b"", remote=True)
    assert slcan.decode_status(b"F20") == slcan.STATUS_ERROR_PASSIVE
    for bad in (b"t12", b"t1233DEAD", b"t123XDEAD", b"t1232ZZZZ", b"x1232DEAD", b"t1239" + b"00" * 9):
        with pytest.raises(FrameError):
            slcan.decode_frame(bad)
    with pytest.raises(FrameError):
        slcan.decode_status(b"FZZ")


def test_a_stream_splits_into_lines_and_a_rest() -> None:
    assert slcan.split_lines(b"t0011AA\rz\r\rt00") == ([b"t0011AA", b"z", b""], b"t00")
    assert slcan.split_lines(b"\at0011AA\r") == ([b"\a", b"t0011AA"], b"")  # a refusal has no carriage return of its own


@pytest.fixture
def adapter() -> Iterator[tuple[int, str]]:
    """A pseudo-terminal standing for a USB-CAN adapter: the test holds the adapter's end, the bus opens the other."""
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    os.close(slave)
    try:
        yield master, path
    finally:
        os.close(master)


def read_all(fd: int, timeout: float = 1.0) -> bytes:
    """What the bus wrote to the adapter's end (until it was quiet for 50 ms, or closed its end: EIO)."""
    data = b""
    while select.select([fd], [], [], timeout)[0]:
        try:
            data += os.read(fd, 65536)
        except OSError:  # EIO: nothing holds the other end any more
            break
        timeout = 0.05
    return data


def test_the_bus_opens_the_channel_sends_a_batch_in_one_write_and_reads_what_came(adapter: tuple[int, str]) -> None:
    fd, path = adapter
    with SlcanBus(path, bitrate=1_000_000) as bus:
        assert read_all(fd) == b"C\rS8\rO\r"  # close, 1 Mbit/s, open
        frames = [can.Message(arbitration_id=i, data=bytes([i] * 8), is_extended_id=False) for i in (1, 2, 3)]
        bus.send_batch(frames)
        assert read_all(fd) == b"".join(slcan.encode_frame(i, bytes([i] * 8)) for i in (1, 2, 3))
        bus.send(frames[0])
        assert read_all(fd) == slcan.encode_frame(1, bytes([1] * 8))
        # The adapter's answers, a refusal, two frames split across writes, a line that is nothing, a bus error.
        os.write(fd, b"\r\rz\r\at0042ABCD\rt00")
        os.write(fd, b"51EE\rnonsense\rF80\r")
        received = [bus.recv(timeout=1.0) for _ in range(3)]
        assert [(m.arbitration_id, bytes(m.data)) for m in received[:2]] == [(4, b"\xab\xcd"), (5, b"\xee")]
        assert received[2].is_error_frame and received[2].arbitration_id == CAN_ERR_BUSOFF
        assert bus.recv(timeout=0.05) is None and bus.refusals == 1 and bus.malformed == 1
        os.write(fd, b"F20\r")
        error = bus.recv(timeout=1.0)
        assert error.is_error_frame and error.arbitration_id == CAN_ERR_CRTL
    assert read_all(fd).endswith(b"C\r")  # shut down: the channel closed


def test_a_far_end_that_hangs_up_is_an_operation_error() -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    bus = SlcanBus(os.ttyname(slave))
    os.close(slave)
    try:
        assert bus.recv(timeout=0.01) is None  # nothing yet: the adapter is still there
        os.close(master)  # the adapter is pulled (the robot process's end of the pseudo-terminal closes)
        with pytest.raises(can.CanOperationError, match="hung up|read failed"):
            bus.recv(timeout=0.5)
    finally:
        bus.shutdown()


def test_a_missing_or_busy_adapter_is_one_bus_error_naming_the_bus(adapter: tuple[int, str]) -> None:
    fd, path = adapter
    missing = BusConfig(kind="can", interface="slcan", channel="/dev/ttyACM-nope")
    with pytest.raises(BusError) as info:
        open_can("can0", missing)
    assert str(info.value).startswith("cannot open CAN bus 'can0' (slcan:/dev/ttyACM-nope): cannot open slcan port /dev/ttyACM-nope:")
    assert "\n" not in str(info.value) and "no other program holding it" in str(info.value)
    holder = serial.Serial(path, exclusive=True)  # another program has the adapter
    try:
        with pytest.raises(BusError, match=r"^cannot open CAN bus 'can1' \(slcan:.*\): cannot open slcan port .*lock"):
            open_can("can1", BusConfig(kind="can", interface="slcan", channel=path))
    finally:
        holder.close()
    assert read_all(fd, 0.1) == b""  # nothing reached the adapter
