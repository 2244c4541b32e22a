"""How `g1ctl sim` reaches the simulated G1: directly, or through simulated hardware.

`DirectBackend`: the controller writes joint commands into MuJoCo's PD servos.
`HardwareBackend`: the controller drives a `HardwareRobot` over the codecs and buses of
a hardware config, with firmware emulators and MuJoCo behind them; one bus cycle per
physics step (500 Hz), in lockstep with simulated time.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

from controller.runtime.tracking_metrics import percentiles_ms
from hw.emulation.faults import load_faults
from hw.emulation.rig import SimulatedHardware
from hw.hardware_robot import HardwareRobot, Lifecycle
from hw.jointmap import load_hardware_config
from hw.robot import RobotInterface
from sim.hardware_twin import MuJoCoPlant
from sim.robot import SimRobot

# The simulated robot starts in the default pose, so the soft start has nothing to ramp;
# a long ramp would only let the un-balanced robot sag. Waiting on the emulators costs
# no simulated time, so replies may take longer in wall time than on real hardware.
SIM_SOFT_START_S = 0.2
SIM_CYCLE_TIMEOUT_S = 0.006


class DirectBackend:
    def __init__(self, truth: SimRobot) -> None:
        self.truth = truth
        self.robot: RobotInterface = truth

    def advance_to(self, t: float) -> None:
        self.truth.step_until(t)

    def recover_from_fall(self) -> bool:
        self.truth.reset()
        return True

    def fault(self) -> str | None:
        return None

    def report(self) -> dict[str, Any] | None:
        return None

    def close(self) -> None:
        self.truth.close()


class HardwareBackend:
    def __init__(self, truth: SimRobot, hardware: str, faults: str | None = None) -> None:
        self.truth = truth
        cfg = load_hardware_config(hardware)
        plans = load_faults(faults, list(cfg.buses)) if faults else None
        safety = dataclasses.replace(cfg.safety, soft_start_time=SIM_SOFT_START_S, cycle_timeout=SIM_CYCLE_TIMEOUT_S)
        cfg = dataclasses.replace(cfg, safety=safety)
        self.name = hardware
        self.plant = MuJoCoPlant(truth)
        self.twin = SimulatedHardware(cfg, self.plant, plans)
        self.host = HardwareRobot(self.twin.host_config, stamp_clock=self.plant.time)
        self.robot: RobotInterface = self.host
        self.cycle_times: list[float] = []
        try:
            self.host.configure()
            self.twin.step()
            self.host.activate()
            while self.host.state is Lifecycle.ACTIVATING:
                self._cycle()
        except Exception:
            self.close()
            raise

    def _cycle(self) -> None:
        t0 = time.perf_counter()
        self.host.cycle()
        self.cycle_times.append(time.perf_counter() - t0)
        self.twin.step()

    def advance_to(self, t: float) -> None:
        while self.truth.time < t - 1e-9:
            self._cycle()

    def recover_from_fall(self) -> bool:
        return False  # a robot on hardware is not stood up by software: the run ends

    def fault(self) -> str | None:
        return "; ".join(self.host.faults) if self.host.state is Lifecycle.ERROR else None

    def report(self) -> dict[str, Any]:
        c = self.host.counters()
        return {
            "config": self.name,
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
            "clamped_values": self.host.clamped_values,
            "faults": self.host.fault_count,
            "fault_reasons": self.host.faults,
            "state": self.host.state.value,
        }

    def close(self) -> None:
        try:
            self.host.close()
        finally:
            self.twin.close()
            self.truth.close()
