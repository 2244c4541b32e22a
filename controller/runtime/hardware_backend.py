"""A `HardwareRobot` as a run backend: bus cycles at the config's rate between control ticks.

`HardwareBackend` is what every robot on buses shares: the bring-up (configure, the soft start),
the latched fault, the counters, the damped close. How time moves is the subclass's:

- `SimulatedHardwareBackend` (`runtime/sim_backends.py`): firmware emulators and MuJoCo in this
  process, cycles back to back in simulated time, the physics stepped after each;
- `PacedBusBackend`: buses that run on their own (real ones, or the bus robot in its own
  process), cycles on their deadlines on the wall clock (`loop.CyclePacer`): a cycle that comes
  a whole period late is counted as missed, never caught up with a burst. `RealBusesBackend` is a
  real robot on python-can interfaces and serial ports; `build_real_buses` makes it for the
  registry's `real-buses`.

No MuJoCo here: a run on real buses never loads it.
"""

from __future__ import annotations

import abc
import math
import time
from contextlib import ExitStack
from typing import TYPE_CHECKING, Any

import numpy as np

from controller.reports import percentiles_ms
from controller.runtime.backend import Backend
from controller.runtime.backend_registry import BuiltBackend
from controller.runtime.loop import Clock, CyclePacer, RunClock
from hw import g1, quat
from hw.hardware_robot import HardwareRobot, Lifecycle
from hw.jointmap import HardwareConfig

if TYPE_CHECKING:
    from controller.assets import Assets
    from controller.runtime.run_plan import RunPlan

MAX_TILT_DEG = 60.0  # a fall on a robot without a simulator: the IMU's pelvis tilt past this (as on the G1 over DDS)


class HardwareBackend(Backend):
    def __init__(self, host: HardwareRobot, config_name: str) -> None:
        self.host = host
        self.robot = host
        self.config_name = config_name
        self.cycle_times: list[float] = []  # seconds each `host.cycle()` took

    def start(self) -> None:
        """Configure (find every motor), then the soft start to the default pose; raises HardwareFault on a fault."""
        self.host.configure()
        self._configured()
        self.host.activate()
        while self.host.state is Lifecycle.ACTIVATING:
            self._next_cycle()

    def _configured(self) -> None:
        """After configure, before the soft start (simulated hardware steps its physics once here)."""

    @abc.abstractmethod
    def _next_cycle(self) -> None:
        """Run the next bus cycle when it is due."""

    def cycle(self) -> None:
        t0 = time.perf_counter()
        self.host.cycle()
        self.cycle_times.append(time.perf_counter() - t0)

    def fault(self) -> str | None:
        return "; ".join(self.host.faults) if self.host.state is Lifecycle.ERROR else None

    def report(self) -> dict[str, Any]:
        c = self.host.counters()
        return {
            "config": self.config_name,
            "cycle_ms": percentiles_ms(self.cycle_times),
            "cycles": len(self.cycle_times),
            "frames_sent": c.frames_sent,
            "frames_received": c.frames_received,
            "dropped": c.dropped,
            "late_replies": c.late_replies,
            "crc_errors": c.crc_errors,
            "bad_frames": c.bad_frames,
            "unknown_ids": c.unknown_ids,
            "error_frames": c.error_frames,
        } | self.host.lifecycle_report()

    def close(self) -> None:
        self.host.close()


class PacedBusBackend(HardwareBackend):
    """Buses that run on their own: cycles at `rate_hz` on the wall clock between control ticks, late ones counted."""

    paced_on_wall_clock = True

    def __init__(self, host: HardwareRobot, config_name: str, rate_hz: float, clock: Clock) -> None:
        """`clock`: the run's time line, the one `host` stamps its states with."""
        super().__init__(host, config_name)
        self._clock = clock
        self.pacer = CyclePacer(clock, rate_hz)

    def now(self) -> float:
        return self._clock.now()

    def advance_to(self, t: float) -> None:
        self.pacer.run_until(t, self.cycle)

    def _next_cycle(self) -> None:
        self.pacer.run_next(self.cycle)

    def report(self) -> dict[str, Any]:
        """The counters, with the cycle period the motors saw (`target`, `p50`, `p99` in ms) and the cycles missed."""
        pacer = self.pacer
        period = {"target": round(1e3 * pacer.period, 4)} | percentiles_ms(pacer.periods)
        return super().report() | {"rate_hz": round(1.0 / pacer.period, 3), "cycle_period_ms": period, "missed_cycles": pacer.missed}


class RealBusesBackend(PacedBusBackend):
    """A real robot on python-can interfaces and serial ports: no ground truth; a fall is the IMU's tilt."""

    def has_fallen(self) -> bool:
        if self.host.imu is None or self.host.imu.latest is None:
            return False
        up_z = float(quat.rotate(self.host.read().base_quat, np.array([0.0, 0.0, 1.0]))[2])
        return up_z < math.cos(math.radians(MAX_TILT_DEG))


def bus_config(plan: RunPlan) -> tuple[HardwareConfig, str]:
    if not isinstance(plan.hardware, HardwareConfig) or plan.hardware_name is None:
        raise TypeError(f"a robot on buses needs a bus config, the plan has {type(plan.hardware).__name__}")
    return plan.hardware, plan.hardware_name


def config_joint_limits(cfg: HardwareConfig) -> tuple[np.ndarray, np.ndarray]:
    """The joint map's position limits in G1 order: what planned motion keeps to where no simulator states them."""
    limits = np.array([cfg.joints[joint].position_limits for joint in g1.JOINT_NAMES])
    return limits[:, 0], limits[:, 1]


def build_real_buses(plan: RunPlan, assets: Assets, stack: ExitStack) -> BuiltBackend:
    """The registry's `real-buses`: the config's interfaces and ports opened now (one that cannot be is refused in one
    line naming the bus, before any motor is spoken to), cycles at the config's rate on the wall clock."""
    hardware, name = bus_config(plan)
    clock = RunClock()
    backend = stack.enter_context(RealBusesBackend(HardwareRobot(hardware, stamp_clock=clock.now), name, hardware.cycle_hz, clock))
    backend.host.open()
    return BuiltBackend(backend, None, config_joint_limits(hardware))
