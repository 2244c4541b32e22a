"""Backends on the simulated G1 in this process: driven directly, or through simulated hardware; and their builders.

`DirectSimBackend`: the controller writes joint commands into MuJoCo's PD servos
(`PerturbedSimBackend`: under perturbations). `SimulatedHardwareBackend`: the controller drives
a `HardwareRobot` over the codecs and buses of a hardware config, with firmware emulators and
MuJoCo behind them; one bus cycle per physics step at 500 Hz (at the config's `cycle_hz`: every so many
steps), in lockstep with simulated time.
`build_simulator` and `build_simulated_buses` make them from the plan of a run (the registry's
`simulator` and `simulated-buses`); `simulated_world` is the G1 in MuJoCo they stand on.
"""

from __future__ import annotations

import dataclasses
from contextlib import ExitStack
from typing import TYPE_CHECKING, Any

import numpy as np

from controller.runtime.backend import Backend
from controller.runtime.backend_registry import BuiltBackend
from controller.runtime.hardware_backend import HardwareBackend
from hw.emulation.faults import FaultFile, load_faults
from hw.emulation.faulty_commands import FaultyCommands
from hw.emulation.rig import SimulatedHardware
from hw.g1 import CONTROL_CYCLE_HZ
from hw.hardware_robot import HardwareRobot, Lifecycle
from hw.jointmap import HardwareConfig
from hw.robot import RobotInterface
from hw.types import RobotState
from sim.hardware_twin import MuJoCoPlant
from sim.perturbations import Perturbations, PerturbedRobot, PushForces, apply_to_model, push_schedule
from sim.robot import SimRobot
from sim.world import SceneConfig, build_model

if TYPE_CHECKING:
    from controller.assets import Assets
    from controller.runtime.run_plan import RunPlan

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
        self, truth: SimRobot, cfg: HardwareConfig, config_name: str, faults: FaultFile | None = None, faults_name: str = "",
        perturbations: Perturbations | None = None, duration: float = 0.0, seed: int = 0,
    ) -> None:  # fmt: skip
        """`cfg`: the hardware config (`config_name`: as the run named it). `faults`: a fault plan (`faults_name`: its
        name or path) the emulators and the controller's commands act out. `perturbations`: pushes switched on each bus
        cycle (one physics step), the host seen and commanded through them. `seed`: the run's, for the pushes and the
        IMU's noise."""
        imu_bus = cfg.imu.bus if cfg.imu is not None else None
        plans = load_faults(faults, faults_name, list(cfg.buses), imu_bus) if faults is not None else None
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
        super().__init__(host, config_name)
        self.steps_per_cycle = round(CONTROL_CYCLE_HZ / cfg.cycle_hz)  # physics steps (the motors' control steps) per bus cycle
        rng = np.random.default_rng(seed)
        self.pushes = PushForces(truth, push_schedule(perturbations.pushes if perturbations else None, duration, rng))
        self._wrappers: list[RobotInterface] = []  # outermost last: the controller writes into it
        if perturbations is not None and perturbations.senses:
            self._wrappers.append(PerturbedRobot(host, perturbations, rng))
        if faults is not None and faults.host.start_s is not None:
            self._wrappers.append(FaultyCommands(self._wrappers[-1] if self._wrappers else host, faults.host, plant.time))
        if self._wrappers:
            self.robot = self._wrappers[-1]

    def now(self) -> float:
        return self.sim.time

    def advance_to(self, t: float) -> None:
        """Bus cycles back to back until simulated time reaches `t`, the physics stepped after each."""
        while self.sim.time < t - 1e-9:
            self.cycle()

    def _configured(self) -> None:
        self.twin.step()

    def _next_cycle(self) -> None:
        self.cycle()

    def cycle(self) -> None:
        self.pushes.apply()
        super().cycle()
        for _ in range(self.steps_per_cycle):
            self.twin.step()

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


def simulated_world(plan: RunPlan, assets: Assets, stack: ExitStack) -> SimRobot:
    """The G1 in MuJoCo on the plan's terrain, its perturbations (friction, payload, strength) in the model; closed by `stack`."""
    perturbations = plan.perturbations
    ground = perturbations.terrain_height_m if perturbations is not None else 0.0
    world = SimRobot(build_model(assets.g1_mjcf, SceneConfig(terrain_height=ground, terrain_seed=plan.seed)))
    stack.callback(world.close)
    if perturbations is not None:
        apply_to_model(world.model, perturbations)
    return world


def build_simulator(plan: RunPlan, assets: Assets, stack: ExitStack) -> BuiltBackend:
    """The registry's `simulator`: MuJoCo commanded directly, under the plan's perturbations when there are any."""
    world = simulated_world(plan, assets, stack)
    if plan.perturbations is None:
        backend: DirectSimBackend = stack.enter_context(DirectSimBackend(world))
        return BuiltBackend(backend, world, world.joint_limits())
    perturbed = stack.enter_context(PerturbedSimBackend(world, plan.perturbations, plan.duration or 0.0, plan.seed))
    return BuiltBackend(perturbed, world, world.joint_limits(), pushes=perturbed.pushes)


def build_simulated_buses(plan: RunPlan, assets: Assets, stack: ExitStack) -> BuiltBackend:
    """The registry's `simulated-buses`: the plan's bus config over firmware emulators, MuJoCo behind them."""
    if not isinstance(plan.hardware, HardwareConfig) or plan.hardware_name is None:
        raise TypeError(f"simulated buses need a bus config, the plan has {type(plan.hardware).__name__}")
    world = simulated_world(plan, assets, stack)
    backend = SimulatedHardwareBackend(
        world, plan.hardware, plan.hardware_name, plan.faults, plan.faults_name or "", plan.perturbations, plan.duration or 0.0,
        plan.seed,
    )  # fmt: skip
    stack.enter_context(backend)
    return BuiltBackend(backend, world, world.joint_limits(), pushes=backend.pushes)
