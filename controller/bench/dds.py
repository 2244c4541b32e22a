"""`g1ctl bench dds`: the host's 500 Hz cycle with the G1 over DDS against a raw Cyclone DDS round trip.

Measured in one run on loopback, as `bench hw` does for CAN: half-second slices of one and then
the other, both partners running throughout, so that the machine's drift falls on both alike.

- Stack: the full `DdsRobot.cycle()` (safety layer, `LowCmd_` encoded with `mode_machine` and
  CRC, published; the answer waited for, taken, decoded, CRC-checked and checked for faults)
  against the simulated G1 in its own process (`g1ctl robot --dds --lockstep --gantry`): it
  answers every command at once with its newest `LowState_` and runs its physics after.
- Raw: the same message sizes through the same Cyclone DDS calls and nothing else: 1004 bytes
  out, a process that answers each with 2092 bytes, the answer taken.

Both partners are child processes on the CPUs the host loop does not use (with `--cpu`). A
state already waiting is drained before each timed cycle, so every figure is a round trip.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import time
from contextlib import ExitStack
from typing import Any

import numpy as np

from controller.reports import percentiles_ms
from controller.runtime.dds_backend import RobotProcess
from controller.runtime.loop import RateLoop, WallClock
from hw import g1
from hw.dds.config import DdsHardwareConfig
from hw.dds.robot import DdsRobot
from hw.dds.session import DdsConfig
from hw.errors import ConfigError, HardwareFault
from hw.jointmap import load_robot_config
from hw.realtime import last_cpu, request_realtime
from hw.robot import Lifecycle
from hw.types import JointCommand

RATE_HZ = g1.CONTROL_CYCLE_HZ
PERIOD_S = 1.0 / RATE_HZ
SLICE_S = 0.5
WARMUP_PERIODS = 25  # each slice's first 50 ms: run, not timed
BENCH_SOFT_START_S = 0.2
RAW_COMMAND_TOPIC, RAW_STATE_TOPIC = "bench/raw_lowcmd", "bench/raw_lowstate"


def serve_raw_echo(domain: int, interface: str, seconds: float) -> None:
    """The raw partner: every message on the command topic answered at once with a fixed `LowState_`-sized one."""
    from hw.dds import cdr, messages  # noqa: PLC0415
    from hw.dds.session import DdsSession  # noqa: PLC0415
    from hw.protocols import unitree_hg as hg  # noqa: PLC0415

    session = DdsSession(DdsConfig(domain=domain, interface=interface))
    commands = session.reader(RAW_COMMAND_TOPIC, messages.LowCmd_)
    answers = session.writer(RAW_STATE_TOPIC, messages.LowState_)
    arrived = session.wait_set(commands)
    answer = cdr.low_state_to_cdr(hg.with_crc(np.zeros((), dtype=hg.LOW_STATE)))
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        arrived(0.05)
        for _ in DdsSession.take_cdr(commands):
            DdsSession.write_cdr(answers, answer)
    session.close()


class RawRoundTrip:
    """The reference: write 1004 bytes of CDR, wait for the echo process's 2092, take them."""

    def __init__(self, dds: DdsConfig, seconds: float) -> None:
        from hw.dds import cdr, messages  # noqa: PLC0415
        from hw.dds.session import DdsSession  # noqa: PLC0415
        from hw.protocols import unitree_hg as hg  # noqa: PLC0415

        code = f"from controller.bench.dds import serve_raw_echo; serve_raw_echo({dds.domain}, {dds.interface!r}, {seconds + 30.0})"
        self.process = subprocess.Popen([sys.executable, "-c", code])
        self._take = DdsSession.take_cdr
        self._write = DdsSession.write_cdr
        self.session = DdsSession(dds)
        self.writer = self.session.writer(RAW_COMMAND_TOPIC, messages.LowCmd_)
        self.reader = self.session.reader(RAW_STATE_TOPIC, messages.LowState_)
        self.wait = self.session.wait_set(self.reader)
        self.command = cdr.low_cmd_to_cdr(hg.with_crc(np.zeros((), dtype=hg.LOW_CMD)))
        self._await_echo()

    def _await_echo(self, timeout_s: float = 20.0) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.round_trip()[1] == 0:
                return
            if self.process.poll() is not None:
                break
        raise HardwareFault(f"the raw echo process did not answer within {timeout_s:g} s (exit code {self.process.poll()})")

    def round_trip(self) -> tuple[float, int]:
        """Seconds from the write to the answer taken, and 1 when no answer came within the period."""
        self._take(self.reader)  # an answer that missed its round trip must not stand in for this one
        t0 = time.perf_counter()
        self._write(self.writer, self.command)
        self.wait(PERIOD_S)
        got = self._take(self.reader)
        return time.perf_counter() - t0, 0 if got else 1

    def close(self) -> None:
        self.session.close()
        self.process.terminate()
        self.process.wait(10)


class StackCycle:
    """The stack under test: configured (motion service released), soft-started, holding the default pose."""

    def __init__(self, cfg: DdsHardwareConfig, assets_dir: str | None, stack: ExitStack) -> None:
        self.process = RobotProcess(cfg, assets_dir, extra_args=("--lockstep", "--gantry"), truth=False)
        stack.callback(self.process.stop)
        self.robot = stack.enter_context(DdsRobot(cfg))
        self.robot.configure()
        self.robot.activate()
        for _ in RateLoop(WallClock(), RATE_HZ).run():
            if self.robot.state is not Lifecycle.ACTIVATING:
                break
            self.robot.cycle(wait_s=PERIOD_S)
        n = g1.NUM_JOINTS
        kp = np.array([cfg.joints[name].kp for name in g1.JOINT_NAMES])
        kd = np.array([cfg.joints[name].kd for name in g1.JOINT_NAMES])
        self.robot.write(JointCommand(q=self.robot.default_pose, dq=np.zeros(n), kp=kp, kd=kd, tau_ff=np.zeros(n)))

    def cycle(self) -> tuple[float, bool]:
        """Seconds for one host cycle, and whether its answer was missing."""
        robot = self.robot
        assert robot.link is not None
        robot.link.poll()  # drain: the timed cycle must wait for its own answer
        received = robot.link.counters.states_received
        t0 = time.perf_counter()
        robot.cycle(wait_s=PERIOD_S)
        elapsed = time.perf_counter() - t0
        if robot.state is not Lifecycle.ACTIVE:
            raise HardwareFault(f"the stack faulted during the benchmark: {'; '.join(robot.faults)}")
        return elapsed, robot.link.counters.states_received == received


def run_dds_bench(
    seconds: float, rt_priority: int = 0, cpu: int | None = None, hardware: str = "sim-dds", assets_dir: str | None = None
) -> dict[str, Any]:
    """Half-second slices of stack cycles and raw round trips, alternating, each at 500 Hz.
    `cpu`: pin the host loop to it (None: the last CPU; -1: no pinning); the partners get the other CPUs."""
    cfg = load_robot_config(hardware)
    if not isinstance(cfg, DdsHardwareConfig) or not cfg.simulated:
        raise ConfigError(f"bench dds needs a simulated DDS hardware config (sim-dds), not '{hardware}'")
    cfg = dataclasses.replace(cfg, safety=dataclasses.replace(cfg.safety, soft_start_time=BENCH_SOFT_START_S))
    pinned = last_cpu() if cpu is None else None if cpu < 0 else cpu
    stack_times: list[float] = []
    raw_times: list[float] = []
    missed = raw_missed = 0
    with ExitStack() as resources:
        under_test = StackCycle(cfg, assets_dir, resources)
        raw = RawRoundTrip(cfg.dds, seconds)
        resources.callback(raw.close)
        if pinned is not None:
            others = set(os.sched_getaffinity(0)) - {pinned}
            for pid in (under_test.process.pid, raw.process.pid):
                os.sched_setaffinity(pid, others or {pinned})
        scheduling = request_realtime(rt_priority, pinned)
        for _ in range(max(round(seconds / SLICE_S), 1)):
            for tick in RateLoop(WallClock(), RATE_HZ).run(SLICE_S + WARMUP_PERIODS / RATE_HZ):
                elapsed, lost = raw.round_trip()
                if tick >= WARMUP_PERIODS:
                    raw_times.append(elapsed)
                    raw_missed += lost > 0 or elapsed > PERIOD_S
            for tick in RateLoop(WallClock(), RATE_HZ).run(SLICE_S + WARMUP_PERIODS / RATE_HZ):
                elapsed, lost_answer = under_test.cycle()
                if tick >= WARMUP_PERIODS:
                    stack_times.append(elapsed)
                    missed += lost_answer or elapsed > PERIOD_S
        counters = dataclasses.asdict(under_test.robot.counters())
    cycle_ms, raw_ms = percentiles_ms(stack_times), percentiles_ms(raw_times)
    return {
        "benchmark": "dds",
        "config": f"{hardware} (domain {cfg.dds.domain}, {cfg.dds.interface}): the simulated G1 in its own process, lock-step",
        "rate_hz": RATE_HZ,
        "seconds": seconds,
        "cycles": len(stack_times),
        "slices": max(round(seconds / SLICE_S), 1),
        "scheduling": scheduling.describe(),
        "cycle_ms": cycle_ms,
        "raw_round_trip_ms": raw_ms,
        "ratio": round(cycle_ms["p50"] / raw_ms["p50"], 3),
        "missed_cycles": missed,  # stack cycles over the 2 ms period or without their answer
        "raw_missed_cycles": raw_missed,
        "counters": counters,
        "robot_process": under_test.process.stop(),
    }
