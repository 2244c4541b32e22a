"""`g1ctl bench hw`: the host bus cycle for 29 motors on four simulated CAN buses at 500 Hz.

Measured in one run, in alternating slices, against the raw python-can round trip of the same frames with a
trivial echo responder on each bus. The stack side is the full `HardwareRobot.cycle()`
(safety layer, encode, send, collect, decode, feedback checks) against the MIT firmware
emulators of `sim-can`, whose plant holds the joints still (no physics on these cores);
the emulators' control step runs between cycles, outside the timed part, as a motor's
own controller does. Both loops run under the same scheduling, SCHED_FIFO by default
(`--rt-priority`), as a deployed control process would; the report says which was granted.
"""

from __future__ import annotations

import threading
import time
import uuid
from contextlib import ExitStack
from typing import Any

import can
import numpy as np

from controller.loop import RateLoop, WallClock
from controller.metrics import percentiles_ms
from hw import g1
from hw.drivers import BusCounters
from hw.emulation.plant import StaticPlant
from hw.emulation.rig import SimulatedHardware
from hw.hardware_robot import HardwareRobot, Lifecycle
from hw.jointmap import HardwareConfig, load_hardware_config
from hw.protocols import mit
from hw.realtime import request_realtime
from hw.types import JointCommand

RATE_HZ = 500.0
WARMUP_CYCLES = 25  # each slice's first 50 ms settle caches and threads; they are run, not timed (both loops)


def _can_only(cfg: HardwareConfig) -> HardwareConfig:
    """The benchmark times the CAN buses: drop the IMU port."""
    import dataclasses  # noqa: PLC0415

    buses = {k: v for k, v in cfg.buses.items() if v.kind == "can"}
    return dataclasses.replace(cfg, buses=buses, imu=None)


def raw_round_trip(cfg: HardwareConfig, cycles: int) -> tuple[list[float], int]:
    """Send the same 29 command frames, have an echo thread per bus return each, time each cycle."""
    token = uuid.uuid4().hex[:8]
    frames: dict[str, list[can.Message]] = {}
    for joint in cfg.joints.values():
        data = mit.encode_command(mit.MitRanges(12.5, 40.0, 100.0), 0.1, 0.0, 20.0, 1.0, 0.0)
        frames.setdefault(joint.bus, []).append(can.Message(arbitration_id=joint.id, data=data, is_extended_id=False))
    hosts = {b: can.Bus(interface="virtual", channel=f"raw-{b}-{token}") for b in frames}
    echoes = {b: can.Bus(interface="virtual", channel=f"raw-{b}-{token}") for b in frames}
    running = True

    def echo(bus: can.BusABC) -> None:
        while running:
            msg = bus.recv(timeout=0.05)
            if msg is not None:
                bus.send(can.Message(arbitration_id=msg.arbitration_id, data=msg.data, is_extended_id=False))

    threads = [threading.Thread(target=echo, args=(bus,), daemon=True) for bus in echoes.values()]
    for t in threads:
        t.start()
    times, missed = [], 0
    loop = RateLoop(WallClock(), RATE_HZ)
    try:
        for i, _ in enumerate(loop.run((cycles + WARMUP_CYCLES) / RATE_HZ)):
            t0 = time.perf_counter()
            deadline = time.monotonic() + 0.002
            for name, bus in hosts.items():
                for msg in frames[name]:
                    bus.send(msg)
            lost = 0
            for name, bus in hosts.items():
                expected = len(frames[name])
                while expected and bus.recv(timeout=max(deadline - time.monotonic(), 0.0)) is not None:
                    expected -= 1
                lost += expected
            elapsed = time.perf_counter() - t0
            if i >= WARMUP_CYCLES:
                times.append(elapsed)
                missed += lost > 0 or elapsed > 1.0 / RATE_HZ
    finally:
        running = False
        for t in threads:
            t.join(timeout=1.0)
        for bus in (*hosts.values(), *echoes.values()):
            bus.shutdown()
    return times, missed


class _StackRig:
    """The stack under test, opened once and run in slices between raw measurements."""

    def __init__(self, cfg: HardwareConfig, stack: ExitStack) -> None:
        plant = StaticPlant(g1.DEFAULT_JOINT_POS | {j: 0.0 for j in g1.JOINT_NAMES if j not in g1.DEFAULT_JOINT_POS})
        self.rig = stack.enter_context(SimulatedHardware(cfg, plant))
        self.host = stack.enter_context(HardwareRobot(self.rig.host_config))
        self.host.configure()
        self.host.activate()
        while self.host.state is Lifecycle.ACTIVATING:
            self.host.cycle()
            self.rig.step()
        n = g1.NUM_JOINTS
        self.host.write(JointCommand(q=self.host.default_pose, dq=np.zeros(n), kp=np.full(n, 20.0), kd=np.ones(n), tau_ff=np.zeros(n)))
        self.times: list[float] = []
        self.missed = 0

    def run(self, seconds: float) -> None:
        host, period = self.host, 1.0 / RATE_HZ
        for i, _ in enumerate(RateLoop(WallClock(), RATE_HZ).run(seconds + WARMUP_CYCLES / RATE_HZ)):
            dropped = host.counters().dropped
            t0 = time.perf_counter()
            host.cycle()
            elapsed = time.perf_counter() - t0
            if i >= WARMUP_CYCLES:
                self.times.append(elapsed)
                self.missed += host.counters().dropped > dropped or elapsed > period
            self.rig.step()  # the motors' control step: on hardware it runs on their own processors
        if host.state is not Lifecycle.ACTIVE:
            raise RuntimeError(f"the stack faulted during the benchmark: {host.faults}")


def run_hw_bench(seconds: float, raw_seconds: float, rt_priority: int = 0) -> dict[str, Any]:
    """Alternate slices of raw round trips and stack cycles, so both see the same machine load and scheduling."""
    scheduling = request_realtime(rt_priority)
    cfg = _can_only(load_hardware_config("sim-can"))
    slices = max(int(seconds // 6), 1)
    raw: list[float] = []
    raw_missed = missed = 0
    stack_times: list[float] = []
    counters = BusCounters()
    for _ in range(slices):
        times, lost = raw_round_trip(cfg, round(raw_seconds / slices * RATE_HZ))
        raw += times
        raw_missed += lost
        with ExitStack() as stack:  # a fresh stack per slice: a paused host would rightly trip its watchdog
            under_test = _StackRig(cfg, stack)
            under_test.run(seconds / slices)
            stack_times += under_test.times
            missed += under_test.missed
            counters.add(under_test.host.counters())
    cycle_ms, raw_ms = percentiles_ms(stack_times), percentiles_ms(raw)
    return {
        "benchmark": "hw",
        "config": "sim-can (4 virtual CAN buses, 29 MIT motors)",
        "rate_hz": RATE_HZ,
        "seconds": seconds,
        "cycles": len(stack_times),
        "slices": slices,
        "scheduling": scheduling.describe(),
        "cycle_ms": cycle_ms,
        "raw_round_trip_ms": raw_ms,
        "ratio": round(cycle_ms["p50"] / raw_ms["p50"], 3),
        "missed_cycles": missed,  # cycles longer than the 2 ms period or with a lost reply
        "raw_missed_cycles": raw_missed,
        "counters": vars(counters),
    }
