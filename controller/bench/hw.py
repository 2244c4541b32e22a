"""`g1ctl bench hw`: the host bus cycle for 29 motors on four simulated CAN buses at 500 Hz.

Measured in one run against the raw python-can round trip of the same frames with a
trivial echo responder on each bus: half-second slices of one and then the other, both
rigs open throughout, so that the machine's drift (a third, within seconds, on a shared
machine) falls on both alike.

The stack side is the full `HardwareRobot.cycle()` (safety layer, encode, send, collect,
decode, feedback checks) against the MIT firmware emulators of `sim-can`, whose plant
holds the joints still (no physics on these cores); the emulators' control step runs
between cycles, outside the timed part, as a motor's own controller does. Both loops run
the way a deployed control process would: SCHED_FIFO (`--rt-priority`) with memory
locked, pinned to one CPU (`--cpu`); the report says what was granted.
"""

from __future__ import annotations

import dataclasses
import threading
import time
import uuid
from contextlib import ExitStack
from typing import Any

import can
import numpy as np

from controller.reports import percentiles_ms
from controller.runtime.loop import RateLoop, WallClock
from hw import g1
from hw.emulation.plant import StaticPlant
from hw.emulation.rig import SimulatedHardware
from hw.hardware_robot import HardwareRobot, Lifecycle
from hw.jointmap import HardwareConfig, load_hardware_config
from hw.protocols import mit
from hw.realtime import last_cpu, request_realtime
from hw.types import JointCommand

RATE_HZ = g1.CONTROL_CYCLE_HZ  # the hardware cycle
SLICE_S = 0.5  # stack and raw alternate in slices this long: the machine's speed drifts over seconds
WARMUP_PERIODS = 25  # each slice's first 50 ms settle caches and threads: run, not timed (both loops)
BENCH_SOFT_START_S = 0.2  # the benchmark times the steady state, not the bring-up ramp


def _can_only(cfg: HardwareConfig) -> HardwareConfig:
    """The benchmark times the CAN buses: drop the IMU port."""
    buses = {k: v for k, v in cfg.buses.items() if v.kind == "can"}
    safety = dataclasses.replace(cfg.safety, soft_start_time=BENCH_SOFT_START_S)
    return dataclasses.replace(cfg, buses=buses, imu=None, safety=safety)


class EchoRoundTrip:
    """The reference: the same 29 command frames on the same buses, each echoed back by a
    thread per bus that does nothing else; one call sends them all and waits for every echo."""

    def __init__(self, cfg: HardwareConfig) -> None:
        token = uuid.uuid4().hex[:8]
        data = mit.encode_command(mit.MitRanges(12.5, 40.0, 100.0), 0.1, 0.0, 20.0, 1.0, 0.0)
        self.frames: dict[str, list[can.Message]] = {}
        for joint in cfg.joints.values():
            self.frames.setdefault(joint.bus, []).append(can.Message(arbitration_id=joint.id, data=data, is_extended_id=False))
        self.hosts = {b: can.Bus(interface="virtual", channel=f"raw-{b}-{token}") for b in self.frames}
        self._echoes = [can.Bus(interface="virtual", channel=f"raw-{b}-{token}") for b in self.frames]
        self._running = True
        self._threads = [threading.Thread(target=self._echo, args=(bus,), daemon=True) for bus in self._echoes]
        for t in self._threads:
            t.start()

    def _echo(self, bus: can.BusABC) -> None:
        while self._running:
            msg = bus.recv(timeout=0.05)
            if msg is not None:
                bus.send(can.Message(arbitration_id=msg.arbitration_id, data=msg.data, is_extended_id=False))

    def round_trip(self) -> tuple[float, int]:
        """Seconds for all frames out and all echoes in, and how many echoes did not come within 2 ms."""
        t0 = time.perf_counter()
        deadline = time.monotonic() + 1.0 / RATE_HZ
        for name, bus in self.hosts.items():
            while bus.recv(timeout=0.0) is not None:
                pass  # an echo that missed its round trip's deadline must not stand in for this one's
            for msg in self.frames[name]:
                bus.send(msg)
        lost = 0
        for name, bus in self.hosts.items():
            expected = len(self.frames[name])
            while expected and bus.recv(timeout=max(deadline - time.monotonic(), 0.0)) is not None:
                expected -= 1
            lost += expected
        return time.perf_counter() - t0, lost

    def close(self) -> None:
        self._running = False
        for t in self._threads:
            t.join(timeout=1.0)
        for bus in (*self.hosts.values(), *self._echoes):
            bus.shutdown()


class StackCycle:
    """The stack under test: configured, soft-started and holding the default pose."""

    def __init__(self, cfg: HardwareConfig, stack: ExitStack) -> None:
        plant = StaticPlant(dict(zip(g1.JOINT_NAMES, g1.default_joint_vector(), strict=True)))
        self.rig = stack.enter_context(SimulatedHardware(cfg, plant))
        self.host = stack.enter_context(HardwareRobot(self.rig.host_config))
        self.host.configure()
        self.host.activate()
        for _ in RateLoop(WallClock(), RATE_HZ).run():
            if self.host.state is not Lifecycle.ACTIVATING:
                break
            self.host.cycle()
            self.rig.step()
        n = g1.NUM_JOINTS
        self.host.write(JointCommand(q=self.host.default_pose, dq=np.zeros(n), kp=np.full(n, 20.0), kd=np.ones(n), tau_ff=np.zeros(n)))

    def cycle(self) -> tuple[float, bool]:
        """Seconds for one host cycle, and whether a reply was lost in it."""
        host = self.host
        dropped = host.counters().dropped
        t0 = time.perf_counter()
        host.cycle()
        elapsed = time.perf_counter() - t0
        if host.state is not Lifecycle.ACTIVE:
            raise RuntimeError(f"the stack faulted during the benchmark: {host.faults}")
        return elapsed, host.counters().dropped > dropped


def run_hw_bench(seconds: float, rt_priority: int = 0, cpu: int | None = None) -> dict[str, Any]:
    """Half-second slices of stack cycles and raw round trips, alternating, each at 500 Hz.
    `cpu`: pin the process to it (None: the last CPU; -1: no pinning)."""
    scheduling = request_realtime(rt_priority, last_cpu() if cpu is None else None if cpu < 0 else cpu)
    cfg = _can_only(load_hardware_config("sim-can"))
    stack_times: list[float] = []
    raw_times: list[float] = []
    missed = raw_missed = 0
    with ExitStack() as resources:
        under_test = StackCycle(cfg, resources)
        echo = EchoRoundTrip(cfg)
        resources.callback(echo.close)
        for _ in range(max(round(seconds / SLICE_S), 1)):
            for tick in RateLoop(WallClock(), RATE_HZ).run(SLICE_S + WARMUP_PERIODS / RATE_HZ):
                elapsed, lost = echo.round_trip()
                if tick >= WARMUP_PERIODS:
                    raw_times.append(elapsed)
                    raw_missed += lost > 0 or elapsed > 1.0 / RATE_HZ
            for tick in RateLoop(WallClock(), RATE_HZ).run(SLICE_S + WARMUP_PERIODS / RATE_HZ):
                elapsed, lost_reply = under_test.cycle()
                under_test.rig.step()  # the motors' control step: on hardware it runs on their own processors
                if tick >= WARMUP_PERIODS:
                    stack_times.append(elapsed)
                    missed += lost_reply or elapsed > 1.0 / RATE_HZ
        counters = under_test.host.counters()
    cycle_ms, raw_ms = percentiles_ms(stack_times), percentiles_ms(raw_times)
    return {
        "benchmark": "hw",
        "config": "sim-can (4 virtual CAN buses, 29 MIT motors)",
        "rate_hz": RATE_HZ,
        "seconds": seconds,
        "cycles": len(stack_times),
        "slices": round(seconds / SLICE_S),
        "scheduling": scheduling.describe(),
        "cycle_ms": cycle_ms,
        "raw_round_trip_ms": raw_ms,
        "ratio": round(cycle_ms["p50"] / raw_ms["p50"], 3),
        "missed_cycles": missed,  # stack cycles longer than the 2 ms period or with a lost reply
        "raw_missed_cycles": raw_missed,
        "counters": vars(counters),
    }
