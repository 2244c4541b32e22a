"""`g1ctl bench buses`: the bus rates this machine holds against the bus robot in its own process.

For each rate, a fresh `g1ctl robot --buses` (sim-can-process by default: 29 MIT motors on four
slcan adapters and a serial IMU, MuJoCo and the emulators on the wall clock) and the host's bus
cycle (`HardwareRobot.cycle()`: the safety layer, the frames out, the replies in, the checks)
paced at that rate on the wall clock, holding the default pose, with the control loop's share of
the time left out (no policy: the benchmark asks what the buses sustain). A cycle waits for its
replies at most three quarters of its period. A rate is held when the median cycle period is
within 2 % of its target, at most 2 % of the cycles are missed, and no fault latched. The report
gives each rate's period, missed cycles, cycle time, dropped replies and the robot's physics step,
and the highest rate held.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import numpy as np

from controller.runtime.bus_process import BusRobotProcess, host_config
from controller.runtime.hardware_backend import PacedBusBackend
from controller.runtime.loop import RunClock
from hw.hardware_robot import HardwareRobot
from hw.jointmap import load_hardware_config
from hw.realtime import request_realtime
from hw.types import JointCommand

TICK_S = 0.02  # the host hands the buses their time in control ticks' slices, as a run does
REPLY_SHARE = 0.75  # of the period, what a cycle waits for its replies at most
HELD_PERIOD = 0.02  # a rate is held with its median period this close to the target (relative)
HELD_MISSED = 0.02  # and at most this share of its cycles missed


def measure_rate(hardware: str, rate_hz: float, seconds: float, assets_dir: str | None) -> dict[str, Any]:
    """One rate: the robot process started, the host cycling at `rate_hz` for `seconds` holding the default pose."""
    cfg = load_hardware_config(hardware)
    robot = BusRobotProcess(hardware, assets_dir)
    try:
        timeout = min(cfg.safety.cycle_timeout, REPLY_SHARE / rate_hz)
        host_cfg = dataclasses.replace(
            host_config(cfg, robot.ports), cycle_hz=rate_hz, safety=dataclasses.replace(cfg.safety, cycle_timeout=timeout)
        )
        clock = RunClock()
        with PacedBusBackend(HardwareRobot(host_cfg, stamp_clock=clock.now), hardware, rate_hz, clock) as backend:
            backend.host.open()
            backend.start()
            names = backend.host.joint_names
            kp, kd = (np.array([getattr(host_cfg.joints[name], gain) for name in names]) for gain in ("kp", "kd"))  # bring-up gains
            zeros = np.zeros(len(names))
            backend.host.write(JointCommand(q=backend.host.default_pose, dq=zeros, kp=kp, kd=kd, tau_ff=zeros))
            start = backend.now()
            backend.pacer.periods.clear()
            backend.pacer.missed = backend.pacer.cycles = 0  # the steady state, not the bring-up
            for tick in range(1, round(seconds / TICK_S) + 1):
                backend.advance_to(start + tick * TICK_S)
                if backend.fault() is not None:
                    break
            fault = backend.fault()
        hw = backend.report()
    finally:
        counters = robot.stop()
    pacer = backend.pacer
    slots = pacer.cycles + pacer.missed
    period = hw["cycle_period_ms"]
    missed_share = pacer.missed / slots if slots else 1.0
    held = fault is None and abs(period["p50"] / period["target"] - 1) <= HELD_PERIOD and missed_share <= HELD_MISSED
    return {
        "rate_hz": rate_hz, "held": held, "cycle_period_ms": period, "missed_cycles": pacer.missed, "cycles": pacer.cycles,
        "missed_share": round(missed_share, 4), "cycle_ms": hw["cycle_ms"], "reply_timeout_ms": round(1e3 * timeout, 3),
        "dropped": hw["dropped"], "fault": fault, "robot_step_ms": counters.get("step_ms"), "robot_late_steps": counters.get("late_steps"),
    }  # fmt: skip


def run_bus_robot_bench(
    rates: list[float], seconds: float, hardware: str = "sim-can-process", rt_priority: int = 0, cpu: int | None = None,
    assets_dir: str | None = None,
) -> dict[str, Any]:  # fmt: skip
    """Each rate in turn (fastest last is not required: each is measured on its own robot process)."""
    scheduling = request_realtime(rt_priority, cpu)
    results = [measure_rate(hardware, rate, seconds, assets_dir) for rate in rates]
    held = [r["rate_hz"] for r in results if r["held"]]
    return {
        "benchmark": "buses",
        "hardware": hardware,
        "seconds": seconds,
        "scheduling": scheduling.describe(),
        "load_average": [round(v, 2) for v in os.getloadavg()],
        "rates": results,
        "highest_rate_held": max(held) if held else None,
    }
