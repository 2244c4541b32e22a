"""Bench bring-up operations on a hardware config: scan, monitor, zero, sweep, damp, imu.

Opens the hardware (real buses, or simulated hardware in a virtual gantry), runs one
operation on the bus cycle, prints its table or JSON and returns the exit status: 1 when
the operation did not do what it was asked (a motor missing in a scan, a sweep stopped).
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

from controller.runtime.hardware import open_hardware
from hw import bringup
from hw.errors import ConfigError
from hw.g1 import CONTROL_CYCLE_HZ
from hw.hardware_robot import HardwareRobot
from hw.realtime import request_realtime

OPERATIONS = ("scan", "monitor", "zero", "sweep", "damp", "imu")
SCAN_CYCLES = 5  # bus cycles before reading who answered


@dataclass(frozen=True)
class BringupConfig:
    operation: str
    hardware: str  # hardware config name or path
    joint: str | None = None  # zero, sweep
    seconds: float = 1.0  # monitor, damp, imu
    refresh: float = 0.25  # monitor: seconds between tables
    fraction: float = 0.3  # sweep: share of the joint's range
    speed: float = 0.3  # sweep: rad/s
    rt_priority: int = 0  # SCHED_FIFO priority of the bus cycle (0: normal scheduling)
    cpu: int | None = None  # pin the bus cycle to this CPU
    assets_dir: str | None = None


def run(cfg: BringupConfig) -> int:
    if cfg.operation not in OPERATIONS:
        raise ConfigError(f"unknown bring-up operation '{cfg.operation}' (valid: {', '.join(OPERATIONS)})")
    if cfg.operation in ("zero", "sweep") and not cfg.joint:
        raise ConfigError(f"hw {cfg.operation} needs --joint NAME")
    request_realtime(cfg.rt_priority, cfg.cpu)
    with open_hardware(cfg.hardware, cfg.assets_dir, require_all=cfg.operation != "scan") as (host, pump):
        if cfg.operation == "scan":
            for _ in range(SCAN_CYCLES):
                pump()
            rows = bringup.probe(host)
            print(bringup.format_table(rows, ("bus", "id", "joint", "answered", "position", "temperature", "error")))
            missing = sum(not r["answered"] for r in rows)
            print(f"{len(rows) - missing}/{len(rows)} motors answered")
            return 1 if missing else 0
        if cfg.operation == "monitor":
            monitor(host, pump, cfg.seconds, cfg.refresh)
            return 0
        if cfg.operation == "zero":
            print(json.dumps(bringup.zero(host, str(cfg.joint))))
            return 0
        if cfg.operation == "sweep":
            result = bringup.sweep(host, str(cfg.joint), pump, fraction=cfg.fraction, speed=cfg.speed)
            print(json.dumps(vars(result)))
            return 0 if result.completed else 1
        if cfg.operation == "damp":
            bringup.damp(host, pump, cfg.seconds)
            print(f"damping on every joint ({host.cfg.safety.damping_kd} N m s/rad) for {cfg.seconds} s")
            return 0
        print(json.dumps(bringup.imu_summary(host, pump, cfg.seconds)))
        return 0


def monitor(host: HardwareRobot, pump: Callable[[], None], seconds: float, refresh: float) -> None:
    """A live joint table every `refresh` s on a terminal; one table into a log."""
    tty = sys.stdout.isatty()
    cycles = max(int(refresh * CONTROL_CYCLE_HZ), 1)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for _ in range(cycles):
            pump()
        table = bringup.format_table(bringup.monitor_rows(host), ("joint", "q", "dq", "tau", "temp", "error", "age_ms"))
        print(("\x1b[H\x1b[2J" if tty else "") + table, flush=True)
        if not tty:
            break  # a log gets one table, not a stream of them
