"""Backends of `g1ctl sim`: the simulated G1 driven directly, or through simulated hardware.

`DirectSimBackend`: the controller writes joint commands into MuJoCo's PD servos.
`SimulatedHardwareBackend`: the controller drives a `HardwareRobot` over the codecs and
buses of a hardware config, with firmware emulators and MuJoCo behind them; one bus cycle
per physics step (500 Hz), in lockstep with simulated time.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from controller.runtime.backend import Backend
from controller.runtime.hardware_backend import HardwareBackend
from hw.emulation.faults import load_fault_file, load_faults
from hw.emulation.faulty_commands import FaultyCommands
from hw.emulation.rig import SimulatedHardware
from hw.hardware_robot import HardwareRobot, Lifecycle
from hw.jointmap import load_hardware_config
from hw.robot import RobotInterface
from hw.types import RobotState
from sim.hardware_twin import MuJoCoPlant
from sim.perturbations import Perturbations, PerturbedRobot, PushForces, push_schedule
from sim.robot import SimRobot

# The simulated robot starts in the default pose, so the soft start has nothing to ramp;
# a long ramp would only let the un-balanced robot sag. Waiting on the emulators costs
# no simulated time, so replies may take longer in wall time than on real hardware.
SIM_SOFT_START_S = 0.2
SIM_CYCLE_TIMEOUT_S = 0.006
# A robot that faulted (or never came up) stays as it is after the run: its motors are watched this
# much longer, so the wire audit records what each did last (damped, or limp on its own watchdog).
WATCH_AFTER_FAULT_S = 0.2


class DirectSimBackend(Backend):
    measures_base_position = True

    def __init__(self, truth: SimRobot) -> None:
        self.sim = truth
        self.robot = truth

    def now(self) -> float:
        return self.sim.time

    def truth_contacts(self) -> tuple[bool, bool]:
        return self.sim.foot_contacts()

    def advance_to(self, t: float) -> None:
        self.sim.step_until(t)

    def has_fallen(self) -> bool:
        return self.sim.has_fallen()

    def recover_from_fall(self) -> bool:
        self.sim.reset()
        return True

    def close(self) -> None:
        self.sim.close()


class PerturbedSimBackend(DirectSimBackend):
    """The simulated G1 under `Perturbations`: pushes on the pelvis at their times (physics stepped up to each
    push's start and end), the controller's view and commands through `PerturbedRobot`; ground truth unperturbed."""

    def __init__(self, truth: SimRobot, perturbations: Perturbations, duration: float, seed: int) -> None:
        super().__init__(truth)
        rng = np.random.default_rng(seed)  # the run's one generator: the same seed, the same perturbations
        self.pushes = PushForces(truth, push_schedule(perturbations.pushes, duration, rng))
        if perturbations.senses:
            self.robot = PerturbedRobot(truth, perturbations, rng)

    def advance_to(self, t: float) -> None:
        for boundary in self.pushes.boundaries(self.sim.time, t):
            self.sim.step_until(boundary)
            self.pushes.apply()
        self.pushes.apply()
        self.sim.step_until(t)

    def truth(self) -> RobotState:
        return self.sim.read()  # the controller's view is perturbed; the truth is not

    def close(self) -> None:
        if self.robot is not self.sim:
            self.robot.close()
        super().close()


class SimulatedHardwareBackend(HardwareBackend):
    """Hardware over virtual buses and pseudo-terminals, MuJoCo behind the emulators; the simulator is ground truth."""

    def __init__(
        self, truth: SimRobot, hardware: str, faults: str | None = None, perturbations: Perturbations | None = None,
        duration: float = 0.0, seed: int = 0,
    ) -> None:  # fmt: skip
        """`faults`: a fault plan (name or path) the emulators and the controller's commands act out.
        `perturbations`: pushes switched on each bus cycle (one physics step), the host seen and commanded through them.
        `seed`: the run's, for the pushes and the IMU's noise."""
        cfg = load_hardware_config(hardware)
        plan = load_fault_file(faults) if faults else None
        imu_bus = cfg.imu.bus if cfg.imu is not None else None
        plans = load_faults(plan, faults, list(cfg.buses), imu_bus) if plan is not None and faults is not None else None
        safety = dataclasses.replace(cfg.safety, soft_start_time=SIM_SOFT_START_S, cycle_timeout=SIM_CYCLE_TIMEOUT_S)
        cfg = dataclasses.replace(cfg, safety=safety)
        self.sim = truth
        plant = MuJoCoPlant(truth)
        self.twin = SimulatedHardware(cfg, plant, plans, seed)
        try:
            host = HardwareRobot(self.twin.host_config, stamp_clock=plant.time, await_replies=self.twin.await_replies)
        except Exception:
            self.twin.close()
            raise
        super().__init__(host, hardware, now=lambda: truth.time, after_cycle=self.twin.step)
        rng = np.random.default_rng(seed)
        self.pushes = PushForces(truth, push_schedule(perturbations.pushes if perturbations else None, duration, rng))
        self._wrappers: list[RobotInterface] = []  # outermost last: the controller writes into it
        if perturbations is not None and perturbations.senses:
            self._wrappers.append(PerturbedRobot(host, perturbations, rng))
        if plan is not None and plan.host.start_s is not None:
            self._wrappers.append(FaultyCommands(self._wrappers[-1] if self._wrappers else host, plan.host, plant.time))
        if self._wrappers:
            self.robot = self._wrappers[-1]

    def cycle(self) -> None:
        self.pushes.apply()
        super().cycle()

    def report(self) -> dict[str, Any]:
        return super().report() | {"wire": self.twin.audit.report()}

    def truth(self) -> RobotState:
        return self.sim.read()

    def truth_contacts(self) -> tuple[bool, bool]:
        return self.sim.foot_contacts()

    def has_fallen(self) -> bool:
        return self.sim.has_fallen()

    def recover_from_fall(self) -> bool:
        return False  # a robot on hardware is not stood up by software: the run ends

    def close(self) -> None:
        try:
            if self.host.state in (Lifecycle.ERROR, Lifecycle.UNCONFIGURED):  # faulted, or never brought up
                end = self.now() + WATCH_AFTER_FAULT_S
                while self.now() < end:
                    if self.host.state is Lifecycle.ERROR:
                        self.cycle()  # the host keeps damping
                    else:
                        self.twin.step()  # no bus open: the motors keep their own counsel
            for wrapper in reversed(self._wrappers):
                wrapper.close()
            super().close()
        finally:
            self.twin.close()
            self.sim.close()
