"""The `g1ctl hw` bring-up jobs: scan, monitor, zero, sweep, damp, imu, on the bench interface.

Each opens the robot with `controller.runtime.bench_robot.open_robot` (real buses, simulated
buses on a virtual gantry, a G1 over DDS or the simulated one in its own process), makes the one
call of the operation, prints its table or JSON and returns the exit status: 1 when the operation
did not do what it was asked (a motor silent or unhealthy in a scan, a sweep stopped, a zero not
confirmed). Bad input is refused before the robot is opened or a confirmation asked.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from dataclasses import dataclass

from controller.runtime.bench_robot import open_robot
from hw.bench import BenchRobot, check_sweep, format_table
from hw.dds.config import DdsHardwareConfig
from hw.errors import ConfigError, NotConfirmed
from hw.jointmap import load_robot_config
from hw.realtime import request_realtime

OPERATIONS = ("scan", "monitor", "zero", "sweep", "damp", "imu")


@dataclass(frozen=True)
class BringupConfig:
    operation: str
    hardware: str  # hardware config name or path
    joint: str | None = None  # zero, sweep
    seconds: float = 1.0  # monitor, damp, imu
    refresh: float = 0.25  # monitor: seconds between tables
    fraction: float = 0.3  # sweep: share of the joint's range
    speed: float = 0.3  # sweep: rad/s
    yes: bool = False  # zero, sweep: confirmed already (otherwise asked in a terminal)
    rt_priority: int = 0  # SCHED_FIFO priority of the bus cycle (0: normal scheduling)
    cpu: int | None = None  # pin the bus cycle to this CPU
    assets_dir: str | None = None


def check(cfg: BringupConfig) -> None:
    """Refuse what cannot run, before anything is opened or a confirmation is asked."""
    if cfg.operation not in OPERATIONS:
        raise ConfigError(f"unknown bring-up operation '{cfg.operation}' (valid: {', '.join(OPERATIONS)})")
    robot_cfg = load_robot_config(cfg.hardware)
    if cfg.operation == "zero" and isinstance(robot_cfg, DdsHardwareConfig):
        from hw.dds.bench import zero_refusal  # noqa: PLC0415 - the DDS bench only for a DDS config

        raise ConfigError(zero_refusal(cfg.hardware))
    if cfg.operation in ("zero", "sweep") and not cfg.joint:
        raise ConfigError(f"hw {cfg.operation} needs --joint NAME")
    if cfg.operation == "sweep":
        check_sweep(robot_cfg.joints, str(cfg.joint), cfg.fraction, cfg.speed)
    if cfg.operation in ("zero", "sweep") and not cfg.yes and not sys.stdin.isatty():
        raise ConfigError(f"hw {cfg.operation} {cfg.joint} on '{cfg.hardware}' needs confirmation: run it in a terminal or pass --yes")


def run(cfg: BringupConfig) -> int:
    check(cfg)
    if cfg.operation == "sweep" and not cfg.yes and not ask(f"sweep {cfg.joint} on '{cfg.hardware}'?"):
        print("g1ctl: not confirmed; nothing was sent", file=sys.stderr)
        return 1
    request_realtime(cfg.rt_priority, cfg.cpu)
    with open_robot(cfg.hardware, cfg.assets_dir) as robot:
        if cfg.operation == "scan":
            return scan(robot)
        if cfg.operation == "monitor":
            monitor(robot, cfg.seconds, cfg.refresh)
            return 0
        if cfg.operation == "zero":
            try:
                result = robot.zero(str(cfg.joint), confirm=True if cfg.yes else ask)
            except NotConfirmed as exc:
                print(f"g1ctl: {exc}", file=sys.stderr)
                return 1
            print(json.dumps(dataclasses.asdict(result)))
            return 0
        if cfg.operation == "sweep":
            sweep = robot.sweep(str(cfg.joint), fraction=cfg.fraction, speed=cfg.speed)
            print(json.dumps(dataclasses.asdict(sweep)))
            return 0 if sweep.completed else 1
        if cfg.operation == "damp":
            robot.damp(cfg.seconds)
            print(f"damping on every joint for {cfg.seconds} s")
            return 0
        print(json.dumps(dataclasses.asdict(robot.imu(cfg.seconds))))
        return 0


def scan(robot: BenchRobot) -> int:
    rows = robot.scan()
    print(format_table(rows, robot.SCAN_COLUMNS))
    answered, healthy = sum(r.answered for r in rows), sum(r.healthy for r in rows)
    print(f"{answered}/{len(rows)} motors answered; {healthy}/{len(rows)} joints healthy (no error, at most {robot.max_temperature:.0f} C)")
    for note in robot.notes():
        print(note)
    return 0 if rows and healthy == len(rows) else 1


def monitor(robot: BenchRobot, seconds: float, refresh: float) -> None:
    """A live joint table every `refresh` s on a terminal; one table into a log."""
    tty = sys.stdout.isatty()
    for _ in range(max(round(seconds / refresh), 1)):
        robot.hold(refresh)
        print(("\x1b[H\x1b[2J" if tty else "") + format_table(robot.status(), robot.MONITOR_COLUMNS), flush=True)
        if not tty:
            break  # a log gets one table, not a stream of them


def ask(question: str) -> bool:
    """A yes/no question in the terminal (no is the default)."""
    return input(f"{question} [y/N] ").strip().lower() in ("y", "yes")
