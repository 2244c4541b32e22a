"""The slcan (Lawicel) ASCII protocol: CAN frames as lines on a serial link, as USB-CAN adapters speak it.

Pure functions from frames to bytes and back, shared by the host's bus (`hw.slcan`) and the bus
robot's firmware emulators (`hw.emulation.slcan_port`). A line ends in a carriage return:

    t1238DEADBEEF00112233\r   standard frame: 3 hex digits of id, the length, the data in hex
    T0000012382DEAD\r         extended frame: 8 hex digits of id
    r1230\r  R000001230\r     remote frames (no data)
    C\r  S8\r  O\r            close the channel, set the bitrate (S0-S8, 10 kbit/s-1 Mbit/s), open it
    F80\r                     the status flags (Lawicel's `F` answer): bus error, error passive, overruns
    \r  or  \a                the adapter's answer to a command: done, or refused
    z\r  Z\r                  the adapter's answer to a transmitted frame (some send it, some do not)
"""

from __future__ import annotations

from dataclasses import dataclass

from hw.protocols.crc import FrameError

CR = b"\r"
BELL = b"\a"
# The bitrate commands as the CANable's firmware and python-can read them (Lawicel's own adapters take S7 as 800 kbit/s).
BITRATE_COMMANDS = {
    10_000: b"S0", 20_000: b"S1", 50_000: b"S2", 100_000: b"S3", 125_000: b"S4", 250_000: b"S5", 500_000: b"S6",
    750_000: b"S7", 1_000_000: b"S8",
}  # fmt: skip
# Lawicel's status flags (the `F` answer).
STATUS_RX_FULL = 0x01
STATUS_TX_FULL = 0x02
STATUS_ERROR_WARNING = 0x04
STATUS_DATA_OVERRUN = 0x08
STATUS_ERROR_PASSIVE = 0x20
STATUS_ARBITRATION_LOST = 0x40
STATUS_BUS_ERROR = 0x80
MAX_STANDARD_ID = 0x7FF


@dataclass(frozen=True)
class SlcanFrame:
    arbitration_id: int
    data: bytes
    extended: bool = False
    remote: bool = False


def open_commands(bitrate: int) -> bytes:
    """Close the channel, set `bitrate`, open it: what a host sends an adapter first."""
    if bitrate not in BITRATE_COMMANDS:
        raise ValueError(f"slcan has no bitrate {bitrate}: use one of {', '.join(map(str, BITRATE_COMMANDS))}")
    return b"C\r" + BITRATE_COMMANDS[bitrate] + b"\rO\r"


def encode_frame(arbitration_id: int, data: bytes | bytearray, extended: bool = False) -> bytes:
    """One data frame as its line, carriage return included."""
    if len(data) > 8:
        raise ValueError(f"a classic CAN frame carries at most 8 bytes, got {len(data)}")
    if extended:
        return b"T%08X%d%s\r" % (arbitration_id, len(data), data.hex().upper().encode())
    if arbitration_id > MAX_STANDARD_ID:
        raise ValueError(f"standard id {arbitration_id:#x} is over {MAX_STANDARD_ID:#x}: send it as an extended frame")
    return b"t%03X%d%s\r" % (arbitration_id, len(data), data.hex().upper().encode())


def encode_status(flags: int) -> bytes:
    return b"F%02X\r" % flags


def split_lines(buffer: bytes) -> tuple[list[bytes], bytes]:
    """The complete lines in `buffer` (without their carriage return; a refusal, BELL, is a line of its own), and the
    incomplete rest to keep for the next read."""
    if BELL in buffer:
        buffer = buffer.replace(BELL, BELL + CR)
    *lines, rest = buffer.split(CR)
    return lines, rest


def decode_frame(line: bytes) -> SlcanFrame:
    """A frame line (`t`, `T`, `r`, `R`; without its carriage return); FrameError when it is malformed."""
    kind = line[:1]
    id_digits = 8 if kind in (b"T", b"R") else 3
    if kind not in (b"t", b"T", b"r", b"R") or len(line) < id_digits + 2:
        raise FrameError(f"not an slcan frame: {line!r}")
    try:
        arbitration_id = int(line[1 : 1 + id_digits], 16)
        length = int(line[1 + id_digits : 2 + id_digits])
        data = b"" if kind in (b"r", b"R") else bytes.fromhex(line[2 + id_digits :].decode("ascii"))
    except ValueError as exc:
        raise FrameError(f"malformed slcan frame {line!r}: {exc}") from exc
    if length > 8 or (kind in (b"t", b"T") and len(data) != length):
        raise FrameError(f"slcan frame {line!r}: length {length} does not match its data")
    return SlcanFrame(arbitration_id, data, extended=id_digits == 8, remote=kind in (b"r", b"R"))


def decode_status(line: bytes) -> int:
    """The flags of a status line (`Fxx`); FrameError when it is not one."""
    if len(line) != 3 or line[:1] != b"F":
        raise FrameError(f"not an slcan status line: {line!r}")
    try:
        return int(line[1:], 16)
    except ValueError as exc:
        raise FrameError(f"malformed slcan status line {line!r}") from exc
