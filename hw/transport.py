"""Open CAN buses (python-can, any interface) and serial ports (pyserial, device or URL).

Failures become one `BusError` that names the bus and says what to check.
"""

from __future__ import annotations

import errno

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
