"""CRCs of the wire protocols, and CRC-framed checks.

CRC-16/KERMIT (CCITT polynomial, reflected 0x8408, initial value 0, no final xor): the RS-485
motors. CRC-32/MPEG-2 fed 32-bit words (polynomial 0x04C11DB7, initial 0xFFFFFFFF, MSB first,
no final xor): the G1's DDS messages, as Unitree's SDK computes it (`crc32_core`).
"""

from __future__ import annotations

import functools


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


@functools.cache
def _crc32_word_tables() -> tuple[tuple[int, ...], ...]:
    """T[k][b] = (b << 8k) shifted through 32 zero bits of CRC-32 with polynomial 0x04C11DB7, MSB first.

    Built on first use (6 ms): the CAN and RS-485 paths import this module and never need them.
    """

    def through_32_bits(x: int) -> int:
        for _ in range(32):
            x = ((x << 1) ^ 0x04C11DB7) & 0xFFFFFFFF if x & 0x80000000 else (x << 1) & 0xFFFFFFFF
        return x

    return tuple(tuple(through_32_bits(b << (8 * k)) for b in range(256)) for k in range(4))


def crc32_mpeg2(data: bytes | bytearray | memoryview, crc: int = 0xFFFFFFFF) -> int:
    """CRC-32/MPEG-2 (polynomial 0x04C11DB7, initial 0xFFFFFFFF, MSB first, no final xor); check of b"123456789": 0x0376E6E7."""
    for byte in data:
        crc ^= byte << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7) & 0xFFFFFFFF if crc & 0x80000000 else (crc << 1) & 0xFFFFFFFF
    return crc


def crc32_words(words: list[int], crc: int = 0xFFFFFFFF) -> int:
    """CRC-32/MPEG-2 over uint32 `words`, each fed most significant bit first (Unitree's `crc32_core`), 32 bits per step."""
    t0, t1, t2, t3 = _crc32_word_tables()
    for word in words:
        x = crc ^ word
        crc = t3[x >> 24] ^ t2[(x >> 16) & 0xFF] ^ t1[(x >> 8) & 0xFF] ^ t0[x & 0xFF]
    return crc
