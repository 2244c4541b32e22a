"""CRCs of the wire protocols, and CRC-framed checks.

CRC-16/KERMIT (CCITT polynomial, reflected 0x8408, initial value 0, no final xor): the RS-485
motors. CRC-32/MPEG-2 fed 32-bit words (polynomial 0x04C11DB7, initial 0xFFFFFFFF, MSB first,
no final xor): the G1's DDS messages, as Unitree's SDK computes it (`crc32_core`).
"""

from __future__ import annotations

import zlib

import numpy as np


def _table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
        table.append(crc)
    return tuple(table)


_TABLE = _table()
BIT_REVERSE_TABLE = bytes(int(f"{b:08b}"[::-1], 2) for b in range(256))  # for `bytes.translate`: each byte's bits mirrored


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


def crc32_mpeg2(data: bytes | bytearray | memoryview, crc: int = 0xFFFFFFFF) -> int:
    """CRC-32/MPEG-2 (polynomial 0x04C11DB7, initial 0xFFFFFFFF, MSB first, no final xor); check of b"123456789": 0x0376E6E7."""
    for byte in data:
        crc ^= byte << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7) & 0xFFFFFFFF if crc & 0x80000000 else (crc << 1) & 0xFFFFFFFF
    return crc


def crc32_words(words: np.ndarray | list[int]) -> int:
    """CRC-32/MPEG-2 over uint32 `words`, each fed most significant bit first (Unitree's `crc32_core`)."""
    return crc32_from_zlib(zlib.crc32(np.asarray(words, dtype=">u4").tobytes().translate(BIT_REVERSE_TABLE)))


def crc32_from_zlib(crc: int) -> int:
    """zlib's CRC-32 of bit-reversed bytes (chained runs allowed) -> their CRC-32/MPEG-2.

    Computed by zlib in C (5-10 us for a `LowState_` instead of 130 us in Python): MPEG-2 is the
    unreflected twin of zlib's CRC-32 (same polynomial, same initial value), so it is zlib's CRC
    over bit-reversed bytes, undone by zlib's final xor and reversed back to 32 bits.
    """
    return int(f"{crc ^ 0xFFFFFFFF:032b}"[::-1], 2)
