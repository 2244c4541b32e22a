"""Serial IMU reader: parse the stream, keep the newest valid sample, count what was wrong."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import serial

from hw.protocols import imu as imu_frame
from hw.protocols.crc import CrcError, FrameError
from hw.protocols.unitree_rs485 import FrameSplitter
from hw.transport import read_waiting


@dataclass
class ImuCounters:
    frames: int = 0
    crc_errors: int = 0
    bad_frames: int = 0
    sequence_gaps: int = 0


class SerialImu:
    def __init__(self, name: str, port: serial.SerialBase, stamp_clock: Callable[[], float] = time.monotonic) -> None:
        self.name = name
        self.port = port
        self.stamp_clock = stamp_clock
        self.counters = ImuCounters()
        self.latest: imu_frame.ImuSample | None = None
        self.stamp: float | None = None
        self.port_fault: str | None = None
        self._splitter = FrameSplitter(imu_frame.HEADER, imu_frame.SIZE)

    def poll(self) -> None:
        """Consume whatever bytes have arrived; never blocks."""
        try:
            data = read_waiting(self.port)
        except (serial.SerialException, OSError) as exc:
            self.port_fault = f"IMU port '{self.name}' read failed: {exc}"
            return
        for frame in self._splitter.feed(data):
            try:
                sample = imu_frame.decode_imu(frame)
            except CrcError:
                self.counters.crc_errors += 1
                continue
            except FrameError:
                self.counters.bad_frames += 1
                continue
            if self.latest is not None and (sample.sequence - self.latest.sequence) & 0xFFFF != 1:
                self.counters.sequence_gaps += 1
            self.latest, self.stamp = sample, self.stamp_clock()
            self.counters.frames += 1

    def age(self, now: float) -> float:
        return float("inf") if self.stamp is None else now - self.stamp

    def close(self) -> None:
        self.port.close()
