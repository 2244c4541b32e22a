"""Run backends by the robot a hardware config names: one entry per kind of robot, and its builder.

A run's hardware config (or none) names a kind of robot (`robot_kind`): the simulator in this
process, simulated buses in this process (sim-can, sim-mixed) or in a robot process of their own
(sim-can-process, sim-mixed-process), the simulated G1 over DDS in its own process (sim-dds), a
real G1 over DDS (g1-dds), a real robot on CAN and serial buses (your bus config with `simulated:
false`). `BACKENDS` maps each kind to what the plan of the run checks before anything starts (what
the backend honours: a video, perturbations, fault plans, real-time scheduling; its clock) and to
the builder that makes it. A kind without an entry is refused in one line that lists the ones
there are.

A new kind of robot is one entry here and its builder. Builders are named as `module:function`
and imported when a run starts, so a run on a real robot never imports MuJoCo.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from controller.runtime.backend import Backend
from hw.dds.config import DdsHardwareConfig
from hw.errors import ConfigError
from hw.jointmap import HardwareConfig, load_robot_config

if TYPE_CHECKING:
    from controller.assets import Assets
    from controller.runtime.run_plan import RunPlan
    from hw.dds.session import DdsConfig
    from sim.perturbations import PushForces
    from sim.robot import SimRobot

RobotConfig = HardwareConfig | DdsHardwareConfig


@dataclass(frozen=True)
class BuiltBackend:
    """What a builder hands the driver: the backend, and what the rest of the run needs from the robot side."""

    backend: Backend
    world: SimRobot | None  # the simulator's model and state (video, viewer, picture, final position, a job's truth); None: a real robot
    joint_limits: tuple[np.ndarray, np.ndarray]  # lower, upper (rad) in G1 order: what planned motion keeps to
    pushes: PushForces | None = None  # the perturbations' pushes on the pelvis, for the report
    remote_dds: DdsConfig | None = None  # where the G1's own remote is read (`--input unitree-remote`): the robot's domain


Builder = Callable[["RunPlan", "Assets", ExitStack], BuiltBackend]


@dataclass(frozen=True)
class BackendEntry:
    """One kind of robot a run drives: what it honours, its clock, and its builder (`module:function`, see `Builder`)."""

    name: str
    build: str
    simulated: bool  # a simulator stands behind the robot: video, picture, viewer, fault drills, a real-time factor
    physics_in_process: bool  # the physics runs in this process: perturbations (pushes, friction, payload ...) reach it
    fault_plans: Literal["buses", "dds"] | None  # which faults a plan may inject: on buses, in a simulated G1 over DDS, none
    clock: Literal["simulated", "wall"]  # simulated: time moves as the loop sleeps; wall: the robot runs on its own
    measures_base_position: bool  # the robot's state carries the base position (the simulator's): the estimator is optional

    def builder(self) -> Builder:
        module, _, function = self.build.partition(":")
        built: Builder = getattr(importlib.import_module(module), function)
        return built


BACKENDS: dict[str, BackendEntry] = {
    # The G1 in MuJoCo in this process, commanded directly.
    "simulator": BackendEntry(
        name="simulator",
        build="controller.runtime.sim_backends:build_simulator", simulated=True, physics_in_process=True, fault_plans=None,
        clock="simulated", measures_base_position=True,
    ),
    # CAN and RS-485 buses with firmware emulators and MuJoCo behind them, in this process (sim-can, sim-mixed).
    "simulated-buses": BackendEntry(
        name="simulated-buses",
        build="controller.runtime.sim_backends:build_simulated_buses", simulated=True, physics_in_process=True, fault_plans="buses",
        clock="simulated", measures_base_position=False,
    ),
    # The simulated G1 in its own process (g1ctl robot --dds), over DDS on loopback (sim-dds).
    "simulated-dds": BackendEntry(
        name="simulated-dds",
        build="controller.runtime.dds_backend:build_simulated_dds", simulated=True, physics_in_process=False, fault_plans="dds",
        clock="wall", measures_base_position=False,
    ),
    # A real G1 over its low-level DDS topics (g1-dds, or your copy).
    "real-dds": BackendEntry(
        name="real-dds",
        build="controller.runtime.dds_backend:build_real_dds", simulated=False, physics_in_process=False, fault_plans=None,
        clock="wall", measures_base_position=False,
    ),
    # The G1 behind the firmware emulators of a bus config in its own process (g1ctl robot --buses), on the wall clock, its
    # pseudo-terminals opened as a real robot's ports (sim-can-process, sim-mixed-process).
    "simulated-buses-process": BackendEntry(
        name="simulated-buses-process",
        build="controller.runtime.bus_process:build_bus_robot_process", simulated=True, physics_in_process=False, fault_plans="buses",
        clock="wall", measures_base_position=False,
    ),
    # A real robot on python-can interfaces and serial ports (a bus config with simulated: false), cycles on the wall clock.
    "real-buses": BackendEntry(
        name="real-buses",
        build="controller.runtime.hardware_backend:build_real_buses", simulated=False, physics_in_process=False, fault_plans=None,
        clock="wall", measures_base_position=False,
    ),
}  # fmt: skip


def robot_kind(hardware: RobotConfig | None) -> str:
    """The kind of robot a hardware config names (None: no hardware config, the simulator directly)."""
    if hardware is None:
        return "simulator"
    if isinstance(hardware, HardwareConfig) and hardware.robot_process:
        return "simulated-buses-process"
    transport = "dds" if isinstance(hardware, DdsHardwareConfig) else "buses"
    return f"{'simulated' if hardware.simulated else 'real'}-{transport}"


def backend_entry(kind: str, source: str) -> BackendEntry:
    """The entry of `kind`; one line naming `source` (what named it) and the kinds there are, when none drives it."""
    try:
        return BACKENDS[kind]
    except KeyError:
        raise ConfigError(
            f"{source} names a {kind} robot, which no run backend drives (run backends: {', '.join(BACKENDS)}); "
            "its bring-up commands: g1ctl hw"
        ) from None


@dataclass(frozen=True)
class BackendChoice:
    """A run's hardware config, loaded and validated once, and the backend entry of the robot it names."""

    hardware_name: str | None  # as given: a shipped name or a path (None: the simulator directly)
    hardware: RobotConfig | None
    entry: BackendEntry


def choose_backend(hardware_name: str | None) -> BackendChoice:
    """Load `hardware_name` (an unknown name or a bad file is one line) and pick its backend."""
    hardware = load_robot_config(hardware_name) if hardware_name is not None else None
    source = f"hardware config '{hardware_name}'" if hardware_name is not None else "no hardware config"
    return BackendChoice(hardware_name, hardware, backend_entry(robot_kind(hardware), source))
