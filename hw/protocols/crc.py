"""CRC-16/KERMIT (CCITT polynomial, reflected 0x8408, initial value 0, no final xor) and CRC-framed checks."""

from __future__ import annotations


def _table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
        table.append(crc)
    return tuple(table)


_TABLE = _table()


def crc16_kermit(data: bytes | bytearray | memoryview, crc: int = 0) -> int:
    """CRC-16/KERMIT of `data`; check value of b"123456789" is 0x2189."""
    for byte in data:
        crc = (crc >> 8) ^ _TABLE[(crc ^ byte) & 0xFF]
    return crc


class FrameError(ValueError):
    """A frame with the wrong length, header or CRC."""


class CrcError(FrameError):
    """A frame whose CRC does not match its bytes: corrupted on the wire (counted apart from malformed frames)."""


def check_crc_frame(frame: bytes, size: int, header: bytes, what: str) -> None:
    """Length, two-byte header and trailing little-endian CRC-16/KERMIT of a fixed-size frame."""
    if len(frame) != size:
        raise FrameError(f"{what} must be {size} bytes, got {len(frame)}")
    if frame[:2] != header:
        raise FrameError(f"{what} header must be {header.hex()}, got {frame[:2].hex()}")
    crc = crc16_kermit(frame[:-2])
    stored = frame[-2] | (frame[-1] << 8)
    if crc != stored:
        raise CrcError(f"{what} CRC mismatch: stored {stored:#06x}, computed {crc:#06x}")
