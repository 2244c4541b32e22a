"""`g1ctl bench dds`: the host's 500 Hz cycle with the G1 over DDS against a raw Cyclone DDS round trip.

Measured in one run on loopback, as `bench hw` does for CAN: half-second slices of one and then
the other, both partners running throughout, so that the machine's drift falls on both alike.

- Stack: the full `DdsRobot.cycle()` (safety layer, `LowCmd_` encoded with `mode_machine` and
  CRC, published; the answer waited for, taken, decoded, CRC-checked and checked for faults)
  against the simulated G1 in its own process (`g1ctl robot --dds --lockstep --gantry`): it
  answers every command at once with its newest `LowState_` and runs its physics after.
- Raw (`raw_round_trip_ms`, `ratio`): Cyclone DDS's public Python API and nothing else, as `bench
  hw` uses python-can: a 1004-byte message written, a process that answers each with 2092 bytes,
  the answer taken (`controller/bench/dds_messages.py`).
- Wire (`raw_wire_round_trip_ms`, `wire_ratio`): the same with already serialized bytes through the
  binding's raw write and take, as the stack sends them: the floor under both.

Both partners are child processes on the CPUs the host loop does not use (with `--cpu`). A
state already waiting is drained before each timed cycle, so every figure is a round trip.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import time
from collections.abc import Callable
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
API_COMMAND_TOPIC, API_STATE_TOPIC = "bench/api_lowcmd", "bench/api_lowstate"
WIRE_COMMAND_TOPIC, WIRE_STATE_TOPIC = "bench/wire_lowcmd", "bench/wire_lowstate"


def serve_echo(domain: int, interface: str, seconds: float) -> None:
    """The raw partner: every message answered at once with a fixed one of `LowState_`'s size, on both references' topics."""
    from controller.bench.dds_messages import RawCmd_, RawState_, raw_state  # noqa: PLC0415
    from hw.dds import cdr, messages  # noqa: PLC0415
    from hw.dds.session import DdsSession  # noqa: PLC0415
    from hw.protocols import unitree_hg as hg  # noqa: PLC0415

    session = DdsSession(DdsConfig(domain=domain, interface=interface))
    api_in, api_out = session.reader(API_COMMAND_TOPIC, RawCmd_), session.writer(API_STATE_TOPIC, RawState_)
    wire_in, wire_out = session.reader(WIRE_COMMAND_TOPIC, messages.LowCmd_), session.writer(WIRE_STATE_TOPIC, messages.LowState_)
    arrived = session.wait_set(api_in, wire_in)
    take, write = DdsSession.cdr_taker(wire_in), DdsSession.cdr_writer(wire_out)
    wire_answer = cdr.low_state_to_cdr(hg.with_crc(np.zeros((), dtype=hg.LOW_STATE)))
    api_answer = raw_state(wire_answer[4:])
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        arrived(0.05)
        for _ in api_in.take(N=4):
            api_out.write(api_answer)
        for _ in take():
            write(wire_answer)
    session.close()


class EchoProcess:
    """The raw references' partner in a child process (`serve_echo`)."""

    def __init__(self, dds: DdsConfig, seconds: float) -> None:
        code = f"from controller.bench.dds import serve_echo; serve_echo({dds.domain}, {dds.interface!r}, {2 * seconds + 60.0})"
        self.process = subprocess.Popen([sys.executable, "-c", code])

    def close(self) -> None:
        self.process.terminate()
        self.process.wait(10)


class RoundTrip:
    """One raw reference: a message of `LowCmd_`'s size out, the echo's answer of `LowState_`'s size taken.

    `api`: through Cyclone DDS's public Python API (`DataWriter.write`, `DataReader.take` of byte-array
    types): cyclonedds used plainly, as `bench hw` uses python-can. Otherwise `wire`: already serialized
    bytes through the binding's raw write and take, as the stack itself sends them: the floor.
    """

    def __init__(self, dds: DdsConfig, echo: EchoProcess, api: bool) -> None:
        from controller.bench.dds_messages import RawCmd_, RawState_, raw_cmd  # noqa: PLC0415
        from hw.dds import cdr, messages  # noqa: PLC0415
        from hw.dds.session import DdsSession  # noqa: PLC0415
        from hw.protocols import unitree_hg as hg  # noqa: PLC0415

        self.echo = echo
        self.session = DdsSession(dds)
        command = cdr.low_cmd_to_cdr(hg.with_crc(np.zeros((), dtype=hg.LOW_CMD)))
        if api:
            writer, reader = self.session.writer(API_COMMAND_TOPIC, RawCmd_), self.session.reader(API_STATE_TOPIC, RawState_)
            message = raw_cmd(command[4:])
            self._write: Callable[[], None] = lambda: writer.write(message)
            self._take: Callable[[], list[Any]] = lambda: reader.take(N=4)
        else:
            writer = self.session.writer(WIRE_COMMAND_TOPIC, messages.LowCmd_)
            reader = self.session.reader(WIRE_STATE_TOPIC, messages.LowState_)
            write, self._take = DdsSession.cdr_writer(writer), DdsSession.cdr_taker(reader)
            self._write = lambda: write(command)
        self.wait = self.session.wait_set(reader)
        self._await_echo()

    def _await_echo(self, timeout_s: float = 20.0) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.round_trip()[1] == 0:
                return
            if self.echo.process.poll() is not None:
                break
        raise HardwareFault(f"the raw echo process did not answer within {timeout_s:g} s (exit code {self.echo.process.poll()})")

    def round_trip(self) -> tuple[float, int]:
        """Seconds from the write to the answer taken, and 1 when no answer came within the period."""
        self._take()  # an answer that missed its round trip must not stand in for this one
        t0 = time.perf_counter()
        self._write()
        self.wait(PERIOD_S)
        got = self._take()
        return time.perf_counter() - t0, 0 if got else 1

    def close(self) -> None:
        self.session.close()


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
    """Half-second slices of stack cycles and both raw round trips, in turn, each at 500 Hz.
    `cpu`: pin the host loop to it (None: the last CPU; -1: no pinning); the partners get the other CPUs."""
    cfg = load_robot_config(hardware)
    if not isinstance(cfg, DdsHardwareConfig) or not cfg.simulated:
        raise ConfigError(f"bench dds needs a simulated DDS hardware config (sim-dds), not '{hardware}'")
    cfg = dataclasses.replace(cfg, safety=dataclasses.replace(cfg.safety, soft_start_time=BENCH_SOFT_START_S))
    pinned = last_cpu() if cpu is None else None if cpu < 0 else cpu
    times: dict[str, list[float]] = {"stack": [], "api": [], "wire": []}
    missed = dict.fromkeys(times, 0)
    with ExitStack() as resources:
        under_test = StackCycle(cfg, assets_dir, resources)
        echo = EchoProcess(cfg.dds, seconds)
        resources.callback(echo.close)
        references = {"api": RoundTrip(cfg.dds, echo, api=True), "wire": RoundTrip(cfg.dds, echo, api=False)}
        for reference in references.values():
            resources.callback(reference.close)
        if pinned is not None:
            others = set(os.sched_getaffinity(0)) - {pinned}
            for pid in (under_test.process.pid, echo.process.pid):
                os.sched_setaffinity(pid, others or {pinned})
        scheduling = request_realtime(rt_priority, pinned)
        loops: dict[str, Callable[[], tuple[float, int | bool]]] = {
            "api": references["api"].round_trip, "wire": references["wire"].round_trip, "stack": under_test.cycle,
        }  # fmt: skip
        for _ in range(max(round(seconds / SLICE_S), 1)):
            for name, one in loops.items():
                for tick in RateLoop(WallClock(), RATE_HZ).run(SLICE_S + WARMUP_PERIODS / RATE_HZ):
                    elapsed, lost = one()
                    if tick >= WARMUP_PERIODS:
                        times[name].append(elapsed)
                        missed[name] += bool(lost) or elapsed > PERIOD_S
        counters = dataclasses.asdict(under_test.robot.counters())
    cycle_ms, api_ms, wire_ms = (percentiles_ms(times[name]) for name in ("stack", "api", "wire"))
    return {
        "benchmark": "dds",
        "config": f"{hardware} (domain {cfg.dds.domain}, {cfg.dds.interface}): the simulated G1 in its own process, lock-step",
        "rate_hz": RATE_HZ,
        "seconds": seconds,
        "cycles": len(times["stack"]),
        "slices": max(round(seconds / SLICE_S), 1),
        "scheduling": scheduling.describe(),
        "cycle_ms": cycle_ms,
        "raw_round_trip_ms": api_ms,  # cyclonedds's public API, messages of the same sizes
        "ratio": round(cycle_ms["p50"] / api_ms["p50"], 3),
        "raw_wire_round_trip_ms": wire_ms,  # already serialized bytes through the binding's raw calls: the floor
        "wire_ratio": round(cycle_ms["p50"] / wire_ms["p50"], 3),
        "missed_cycles": missed["stack"],  # stack cycles over the 2 ms period or without their answer
        "raw_missed_cycles": missed["api"],
        "raw_wire_missed_cycles": missed["wire"],
        "counters": counters,
        "robot_process": under_test.process.stop(),
    }
