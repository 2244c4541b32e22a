"""Bench bring-up operations on a hardware config: scan, monitor, zero, sweep, damp, imu.

Opens the hardware (real buses, or simulated hardware in a virtual gantry; a G1 over DDS, or
the simulated one on a virtual gantry in its own process), runs one operation on the 500 Hz
cycle, prints its table or JSON and returns the exit status: 1 when the operation did not do
what it was asked (a motor missing or unhealthy in a scan, a sweep stopped).
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from controller.runtime.hardware import open_hardware
from hw import bringup
from hw.dds.config import DdsHardwareConfig
from hw.errors import ConfigError
from hw.g1 import CONTROL_CYCLE_HZ, JOINT_NAMES
from hw.jointmap import load_robot_config
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


def check(cfg: BringupConfig) -> None:
    """Refuse what cannot run, before anything is opened or a confirmation is asked."""
    if cfg.operation not in OPERATIONS:
        raise ConfigError(f"unknown bring-up operation '{cfg.operation}' (valid: {', '.join(OPERATIONS)})")
    if cfg.operation == "zero" and isinstance(load_robot_config(cfg.hardware), DdsHardwareConfig):
        raise ConfigError(
            f"hw zero has no meaning on a G1 over DDS ('{cfg.hardware}'): its joint zeros are set at the factory "
            "and its LowCmd_ has no encoder-zero command"
        )
    if cfg.operation in ("zero", "sweep") and not cfg.joint:
        raise ConfigError(f"hw {cfg.operation} needs --joint NAME")


def run(cfg: BringupConfig) -> int:
    check(cfg)
    request_realtime(cfg.rt_priority, cfg.cpu)
    robot_cfg = load_robot_config(cfg.hardware)
    if isinstance(robot_cfg, DdsHardwareConfig):
        return run_dds(cfg, robot_cfg)
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
            monitor(lambda: bringup.monitor_rows(host), pump, cfg.seconds, cfg.refresh)
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


def run_dds(cfg: BringupConfig, robot_cfg: DdsHardwareConfig) -> int:
    """The operations on a G1 over DDS (`zero` is refused by `check`)."""
    from controller.runtime.dds_hardware import open_dds_hardware  # noqa: PLC0415 - cyclonedds only for a DDS config
    from hw.dds import bringup as dds_bringup  # noqa: PLC0415

    if cfg.operation == "sweep":  # refused before the robot's motion service is released
        bringup.check_sweep(robot_cfg.joints, str(cfg.joint), JOINT_NAMES, cfg.fraction, cfg.speed)
    read_only = cfg.operation in ("scan", "monitor", "imu")  # these only listen: the robot's own controller keeps the motors
    with open_dds_hardware(robot_cfg, cfg.assets_dir, read_only=read_only) as (robot, pump):
        if cfg.operation == "scan":
            for _ in range(SCAN_CYCLES):
                pump()
            rows = dds_bringup.scan_rows(robot)
            print(bringup.format_table(rows, dds_bringup.SCAN_COLUMNS))
            healthy = sum(r["healthy"] for r in rows)
            print(f"{healthy}/{len(rows)} joints healthy (no error bits, at most {robot_cfg.safety.max_temperature:.0f} C)")
            record = robot.low_state
            mode_machine = "-" if record is None else int(record["mode_machine"])
            print(f"mode_machine {mode_machine}; high-level motion mode: {dds_bringup.motion_mode(robot)}")
            return 0 if rows and healthy == len(rows) else 1
        if cfg.operation == "monitor":
            monitor(lambda: dds_bringup.monitor_rows(robot), pump, cfg.seconds, cfg.refresh)
            return 0
        if cfg.operation == "sweep":
            result = dds_bringup.sweep(robot, str(cfg.joint), pump, fraction=cfg.fraction, speed=cfg.speed)
            print(json.dumps(vars(result)))
            return 0 if result.completed else 1
        if cfg.operation == "damp":
            dds_bringup.damp(robot, pump, cfg.seconds)
            print(f"damping on every joint ({robot_cfg.safety.damping_kd} N m s/rad) for {cfg.seconds} s")
            return 0
        print(json.dumps(dds_bringup.imu_summary(robot, pump, cfg.seconds)))
        return 0


def monitor(rows: Callable[[], list[dict[str, Any]]], pump: Callable[[], None], seconds: float, refresh: float) -> None:
    """A live joint table every `refresh` s on a terminal; one table into a log."""
    tty = sys.stdout.isatty()
    cycles = max(int(refresh * CONTROL_CYCLE_HZ), 1)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for _ in range(cycles):
            pump()
        table = bringup.format_table(rows(), ("joint", "q", "dq", "tau", "temp", "error", "age_ms"))
        print(("\x1b[H\x1b[2J" if tty else "") + table, flush=True)
        if not tty:
            break  # a log gets one table, not a stream of them
