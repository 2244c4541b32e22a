"""A CAN bus over a serial line in slcan: a USB-CAN adapter (CANable and the like), or the bus robot's pseudo-terminal.

`SlcanBus` is a python-can bus (`can.BusABC`); `hw.transport.open_can` opens it for `interface: slcan`.
It is not python-can's own slcan interface, which reads one byte per system call and drains the
port after every frame: 32 frames each way cost 3 ms over a pseudo-terminal, more than a 2 ms
cycle has. Here a batch of frames leaves in one write (`send_batch`), whatever has arrived is
read in one call and split into frames, the port is locked for this process alone (a second
program on the adapter would interleave its lines with ours), and nothing waits after opening
unless the config says so (`open_delay`: an Arduino-based adapter resets when its port opens).

What comes back besides frames: the adapter's answers to commands (`\\r`, or `\\a` for a refused
one, counted in `refusals`) and to transmitted frames (`z`, `Z`) are taken and dropped; a status
line (`Fxx`) with the bus-error flag is handed on as a bus-off error frame, with error-passive or an
overrun as a controller error frame (`hw.drivers` latches damping on both).
"""

from __future__ import annotations

import collections
import contextlib
import os
import select
import time
from collections.abc import Sequence
from typing import Any

import can
import serial

from hw.protocols import slcan
from hw.protocols.crc import FrameError

CAN_ERR_CRTL = 0x04  # SocketCAN error classes (linux/can/error.h), as python-can's error frames carry them
CAN_ERR_BUSOFF = 0x40


class SlcanBus(can.BusABC):
    def __init__(self, channel: str, bitrate: int = 1_000_000, tty_baudrate: int = 115_200, open_delay: float = 0.0, **kwargs: Any) -> None:
        """`channel`: the adapter's serial device (or a pseudo-terminal). Raises `can.CanInitializationError` when the
        port cannot be opened (absent, held by another program) or the bitrate is not one slcan has."""
        try:
            commands = slcan.open_commands(bitrate)
            self.port = serial.serial_for_url(channel, baudrate=tty_baudrate, timeout=0, write_timeout=0.1, exclusive=True)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise can.CanInitializationError(f"cannot open slcan port {channel}: {exc}") from exc
        self._path = channel
        self._fd = self.port.fileno()
        self._received: collections.deque[can.Message] = collections.deque()
        self._rest = b""
        self.refusals = 0  # commands or frames the adapter refused (BELL)
        self.malformed = 0  # lines that were no frame, answer or status
        if open_delay > 0:
            time.sleep(open_delay)
        try:
            self._write(commands)
        except can.CanOperationError as exc:
            self.port.close()
            raise can.CanInitializationError(str(exc)) from exc
        super().__init__(channel, **kwargs)
        self.channel_info = f"slcan on {channel}"

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self._write(slcan.encode_frame(msg.arbitration_id, bytes(msg.data), msg.is_extended_id))

    def send_batch(self, messages: Sequence[can.Message]) -> None:
        """Every message in one write: the adapter takes the lines as fast as its USB link goes."""
        self._write(b"".join(slcan.encode_frame(m.arbitration_id, bytes(m.data), m.is_extended_id) for m in messages))

    def _write(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except (serial.SerialException, OSError) as exc:
            raise can.CanOperationError(f"slcan port {self._path}: write failed: {exc}") from exc

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if not self._received:
            self._read(timeout)
        return (self._received.popleft() if self._received else None), False

    def _read(self, timeout: float | None) -> None:
        """What has arrived (waiting up to `timeout` for the first byte), split into messages."""
        try:
            ready, _, _ = select.select([self._fd], [], [], timeout)
            if not ready:
                return
            data = os.read(self._fd, 65536)
        except OSError as exc:  # EIO: the adapter was pulled, or the far end of a pseudo-terminal closed
            raise can.CanOperationError(f"slcan port {self._path}: read failed: {exc}") from exc
        if not data:
            raise can.CanOperationError(f"slcan port {self._path}: the device hung up")
        lines, self._rest = slcan.split_lines(self._rest + data)
        for line in lines:
            self._take(line)

    def _take(self, line: bytes) -> None:
        head = line[:1]
        if head in (b"t", b"T", b"r", b"R"):
            try:
                frame = slcan.decode_frame(line)
            except FrameError:
                self.malformed += 1
                return
            self._received.append(
                can.Message(
                    timestamp=time.time(), arbitration_id=frame.arbitration_id, data=frame.data, dlc=len(frame.data),
                    is_extended_id=frame.extended, is_remote_frame=frame.remote, channel=self.channel_info,
                )
            )  # fmt: skip
        elif head == b"F":
            try:
                flags = slcan.decode_status(line)
            except FrameError:
                self.malformed += 1
                return
            error = CAN_ERR_BUSOFF if flags & slcan.STATUS_BUS_ERROR else 0
            if flags & (slcan.STATUS_ERROR_PASSIVE | slcan.STATUS_DATA_OVERRUN):
                error |= CAN_ERR_CRTL
            if error:
                self._received.append(can.Message(timestamp=time.time(), arbitration_id=error, is_error_frame=True, dlc=0))
        elif line == slcan.BELL:
            self.refusals += 1
        elif line not in (b"", b"z", b"Z"):
            self.malformed += 1

    def fileno(self) -> int:
        return self._fd

    def shutdown(self) -> None:
        if self._is_shutdown:
            return
        super().shutdown()
        with contextlib.suppress(serial.SerialException, OSError):  # the adapter may already be gone
            self.port.write(b"C\r")  # close the channel: the adapter leaves the bus
        self.port.close()
