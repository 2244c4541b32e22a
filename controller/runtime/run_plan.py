"""The plan of a run: a `RunConfig` checked and resolved once, before anything starts.

`resolve_run` loads what the config names (the hardware config, once; the scenario; the fault
plan), takes the backend from the registry (`backend_registry`), decides the tracker, the state
estimator and the clock, and refuses in one line whatever cannot run: an unknown name, an option
the backend cannot honour (a video on a real robot, perturbations where the physics runs in
another process, real-time scheduling of a simulated robot). The driver (`runtime/driver.py`)
builds every part of the run from the plan. Nothing here imports MuJoCo.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from controller.inputs.registry import check_input
from controller.inputs.scripted import Scenario, load_scenario
from controller.runtime.backend_registry import BackendChoice, BackendEntry, RobotConfig, choose_backend
from controller.runtime.run_config import RunConfig
from controller.tracking.registry import tracker_for
from hw.dds.config import DdsHardwareConfig
from hw.emulation.faults import FaultFile, check_plan_fits, load_fault_file, load_faults
from hw.errors import ConfigError
from hw.jointmap import HardwareConfig

if TYPE_CHECKING:
    from sim.perturbations import Perturbations

# simulated: time moves as the loop sleeps, as fast as the machine goes; simulated-realtime: the same, held to the wall
# clock (a person drives or watches); wall: the robot runs on its own (a real one, or a simulated one in another process).
RunClockKind = Literal["simulated", "simulated-realtime", "wall"]


@dataclass(frozen=True)
class RunOutputs:
    """What the run writes and shows besides driving the robot."""

    report: Path | None
    plot: Path | None  # the velocity plot: where asked, else beside the report (None: no plot)
    video: Path | None
    video_fps: int
    picture: Path | None  # the final frame
    viewer: bool
    progress: bool
    status: bool
    record: Path | None  # the flight recording (`--record FILE.mcap`)


@dataclass(frozen=True)
class RunPlan:
    """Everything a run is built from, checked: names resolved, files loaded, options fitted to the backend."""

    backend: BackendEntry
    hardware_name: str | None  # as given (None: the simulator directly)
    hardware: RobotConfig | None  # loaded and validated once
    input: str
    scenario_name: str
    scenario: Scenario | None  # the scripted input's timeline (None: another input)
    duration: float | None  # seconds of run time (None: until the input ends it, or Ctrl-C)
    policy: str
    tracker: str
    planner: bool
    seed: int
    clock: RunClockKind
    perturbations: Perturbations | None
    faults_name: str | None
    faults: FaultFile | None
    estimator: bool  # the controller sees the robot through the state estimator
    estimator_config: str | None
    rt_priority: int
    cpu: int | None
    assets_dir: str | None
    outputs: RunOutputs


def resolve_run(cfg: RunConfig, choice: BackendChoice | None = None) -> RunPlan:
    """The plan of `cfg`'s run. `choice`: its hardware config already loaded (`choose_backend(cfg.hardware)`), where
    the caller needed the backend first (to pick defaults); otherwise it is loaded here."""
    if choice is None:
        choice = choose_backend(cfg.hardware)
    elif choice.hardware_name != cfg.hardware:
        raise ValueError(f"the backend was chosen for hardware '{choice.hardware_name}', the run names '{cfg.hardware}'")
    entry = choice.entry
    check_options(cfg, entry)
    check_input(cfg.input, choice.hardware.dds if isinstance(choice.hardware, DdsHardwareConfig) else None)
    scenario = load_scenario(cfg.scenario) if cfg.input == "scripted" else None
    faults = _fault_plan(cfg.faults, choice)
    duration = cfg.duration if cfg.duration is not None else (scenario.duration if scenario else None)
    if duration is not None and duration <= 0:
        raise ConfigError(f"--duration must be positive, got {duration}")
    tracker = tracker_for(cfg.tracker, cfg.planner)
    estimator = cfg.estimator or not entry.measures_base_position
    if cfg.estimator_config is not None and not estimator:
        raise ConfigError("--estimator-config: the simulator measures the base position itself; add --estimator to estimate it")
    outputs = RunOutputs(
        report=cfg.report, plot=cfg.plot or (cfg.report.with_suffix(".png") if cfg.report else None), video=cfg.video,
        video_fps=cfg.video_fps, picture=cfg.picture, viewer=cfg.viewer, progress=cfg.progress, status=cfg.status,
        record=cfg.record,
    )  # fmt: skip
    return RunPlan(
        backend=entry, hardware_name=choice.hardware_name, hardware=choice.hardware, input=cfg.input, scenario_name=cfg.scenario,
        scenario=scenario, duration=duration, policy=cfg.policy, tracker=tracker, planner=cfg.planner, seed=cfg.seed,
        clock=_clock(cfg, entry), perturbations=cfg.perturbations, faults_name=cfg.faults, faults=faults, estimator=estimator,
        estimator_config=cfg.estimator_config, rt_priority=cfg.rt_priority, cpu=cfg.cpu, assets_dir=cfg.assets_dir, outputs=outputs,
    )  # fmt: skip


def check_options(cfg: RunConfig, entry: BackendEntry) -> None:
    """One line for the first option of `cfg` that `entry`'s robot cannot honour."""
    if not entry.simulated:
        unsupported = [name for name, given in (("--video", cfg.video), ("--picture", cfg.picture), ("--viewer", cfg.viewer)) if given]
        if unsupported or cfg.faults:
            raise ConfigError(f"{', '.join(unsupported or ['--faults'])}: not on a real robot (they need the simulator)")
    elif cfg.rt_priority or cfg.cpu is not None:
        raise ConfigError("--rt-priority and --cpu are for a real robot's run (--hardware g1-dds or your copy, or your robot's bus config)")
    if cfg.perturbations is not None and not entry.physics_in_process:
        raise ConfigError("--perturb needs the physics in this process: the simulator, or simulated buses (sim-can, sim-mixed)")
    if cfg.faults is not None and entry.fault_plans is None:
        raise ConfigError("--faults needs --hardware: faults are injected into simulated hardware")


def _fault_plan(name: str | None, choice: BackendChoice) -> FaultFile | None:
    """The fault plan, loaded and fitted to the hardware: a plan for buses on buses the config has, `robot:` faults on DDS."""
    if name is None:
        return None
    plan = load_fault_file(name)
    check_plan_fits(plan, name, choice.entry.fault_plans == "dds")
    hardware = choice.hardware
    if isinstance(hardware, HardwareConfig):  # a bus it lacks, an IMU fault off the IMU's bus: refused now, not at build
        load_faults(plan, name, list(hardware.buses), hardware.imu.bus if hardware.imu is not None else None)
    return plan


def _clock(cfg: RunConfig, entry: BackendEntry) -> RunClockKind:
    if entry.clock == "wall":
        return "wall"
    held = cfg.realtime or cfg.input != "scripted" or cfg.viewer  # a person drives, or watches
    return "simulated-realtime" if held else "simulated"
