"""Open CAN buses (python-can, any interface) and serial ports (pyserial, device or URL).

Failures become one `BusError` that names the bus and says what to check.
"""

from __future__ import annotations

import errno
import os
import select

import can
import serial
import serial.rs485

from hw.errors import BusError
from hw.jointmap import BusConfig
from hw.slcan import SlcanBus


def open_can(name: str, cfg: BusConfig) -> can.BusABC:
    """The bus through python-can; `slcan` through `hw.slcan.SlcanBus` (batched writes, whole reads, an exclusive port)."""
    try:
        if cfg.interface == "slcan":
            return SlcanBus(cfg.channel, bitrate=cfg.bitrate, tty_baudrate=cfg.baudrate, open_delay=cfg.open_delay)
        return can.Bus(interface=cfg.interface, channel=cfg.channel, bitrate=cfg.bitrate, receive_own_messages=False)
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        if cfg.interface == "socketcan" and getattr(exc, "errno", None) == errno.EAFNOSUPPORT:
            hint = "this kernel has no SocketCAN (modprobe can_raw), or this container was not given it"
        else:
            hint = {
                "socketcan": f"is '{cfg.channel}' up? (ip link set {cfg.channel} up type can bitrate {cfg.bitrate})",
                "pcan": "is the PCAN driver installed and the adapter plugged in?",
                "slcan": "is the adapter plugged in, the channel its device path, and no other program holding it?",
            }.get(cfg.interface, "check the interface name and channel in the hardware config")
        raise BusError(f"cannot open CAN bus '{name}' ({cfg.interface}:{cfg.channel}): {exc}; {hint}") from exc


def open_serial(name: str, cfg: BusConfig) -> serial.SerialBase:
    try:
        port = serial.serial_for_url(cfg.port, baudrate=cfg.baudrate, timeout=0, write_timeout=0.1, exclusive=True)
    except (serial.SerialException, OSError, ValueError) as exc:
        raise BusError(
            f"cannot open serial port '{name}' ({cfg.port}): {exc}; check the device path, that no other program holds it, "
            "and that you may read and write it (group dialout)"
        ) from exc
    if cfg.rs485 and isinstance(port, serial.Serial) and not cfg.port.startswith(("/dev/pts/", "loop://")):
        try:
            port.rs485_mode = serial.rs485.RS485Settings(rts_level_for_tx=True, rts_level_for_rx=False)
        except (OSError, ValueError) as exc:  # adapters that switch direction in hardware refuse the ioctl
            port.close()
            raise BusError(
                f"serial port '{name}' ({cfg.port}) refuses RS-485 mode: {exc}; set rs485: false if the adapter switches direction itself"
            ) from exc
    return port


def read_waiting(port: serial.SerialBase) -> bytes:
    """The bytes that have already arrived on `port` (b"" when none have); never waits."""
    waiting = port.in_waiting
    return bytes(port.read(waiting)) if waiting else b""


def read_within(port: serial.SerialBase, timeout: float) -> bytes:
    """What arrives on `port` within `timeout` s: all that has come once the first bytes are there (b"" when none came).
    A device port is waited on directly (one select, one read): pyserial's own timed read reconfigures the port and asks
    what is waiting first, three more system calls on every reply of a half-duplex bus. A port that hung up raises."""
    if not isinstance(port, serial.Serial):  # a pyserial URL (loop://, socket://): its own timed read
        port.timeout = timeout
        return bytes(port.read(max(port.in_waiting, 1) if timeout > 0 else port.in_waiting))
    fd = port.fileno()
    if not select.select([fd], [], [], timeout)[0]:
        return b""
    try:
        data = os.read(fd, 4096)
    except BlockingIOError:
        return b""
    if not data:
        raise serial.SerialException(f"{port.port}: the device hung up")
    return data
