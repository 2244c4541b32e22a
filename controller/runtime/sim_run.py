"""`g1ctl sim`: build a run on the simulated G1, tick it to the end, report on every exit path.

Build: the MuJoCo G1, a tracker chosen by name, a backend (MuJoCo directly, or simulated
hardware), the command input. Run: the session's tick at the tracker's rate on simulated
time (as fast as it goes, or held to the wall clock). Report: whatever ended the run (the
end of the scenario, a fault, a fall on hardware, Ctrl-C, an exception), the JSON report
and its plot are written; an exception is re-raised as `RunAborted` once they are.
This module imports MuJoCo (through `sim`); hardware runs never import it.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from contextlib import ExitStack
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from tqdm import tqdm

from controller.assets import ensure_assets
from controller.inputs.registry import check_input, open_input
from controller.inputs.scripted import load_scenario
from controller.reports import write_report
from controller.runtime.backend import Backend
from controller.runtime.estimation import attach_estimator
from controller.runtime.loop import RateLoop, RealtimeSimulationClock, SimulationClock
from controller.runtime.plots import plot_tracking
from controller.runtime.run_config import RunHooks, SimRunConfig
from controller.runtime.session import Session
from controller.runtime.sim_backends import DirectSimBackend, PerturbedSimBackend, SimulatedHardwareBackend
from controller.runtime.status import StatusLine
from controller.tracking.registry import TrackerSpec, make_tracker
from hw.dds.config import DdsHardwareConfig
from hw.emulation.drill import judge_drill
from hw.emulation.faults import check_plan_fits, load_fault_file
from hw.errors import ConfigError, HardwareFault, MotorNotFoundError, RunAborted
from hw.jointmap import load_robot_config
from sim.perturbations import apply_to_model
from sim.robot import SimRobot
from sim.world import SceneConfig, build_model

if TYPE_CHECKING:
    from controller.reference.source import ReferenceSource


def _check(cfg: SimRunConfig) -> float | None:
    """Input mistakes, found before anything starts; returns the run's duration (None: until stopped)."""
    check_input(cfg.input, cfg.hardware)
    scenario = load_scenario(cfg.scenario) if cfg.input == "scripted" else None
    if cfg.hardware is not None:
        hardware = load_robot_config(cfg.hardware)
        if cfg.faults is not None:
            check_plan_fits(load_fault_file(cfg.faults), cfg.faults, isinstance(hardware, DdsHardwareConfig))
    elif cfg.faults is not None:
        raise ConfigError("--faults needs --hardware: faults are injected into simulated hardware")
    duration = cfg.duration if cfg.duration is not None else (scenario.duration if scenario else None)
    if duration is not None and duration <= 0:
        raise ConfigError(f"--duration must be positive, got {duration}")
    return duration


@dataclass
class _BuiltRun:
    """A run ready to go: the simulated robot, the session on its backend, the loop and the optional outputs."""

    robot: SimRobot
    session: Session
    loop: RateLoop
    recorder: Any  # sim.render.VideoRecorder, when a video is asked for
    viewer: Any  # MuJoCo's passive viewer, with --viewer
    bar: tqdm[Any]
    ghost: Any = None  # sim.render.Ghost drawing the plan in the viewer
    status: StatusLine | None = None
    hooks: RunHooks | None = None


@dataclass(frozen=True)
class _Outcome:
    wall_seconds: float
    interrupted: bool
    error: Exception | None


def run(cfg: SimRunConfig, hooks: RunHooks | None = None) -> dict[str, Any]:
    """Run the scenario and return the report (also written to `cfg.report` when set).

    Raises `RunAborted` (after writing the report) when an exception ended the run.
    """
    duration = _check(cfg)
    if hooks is not None and not cfg.planner:
        raise ConfigError("this run plans whole-body motion: it needs the planner in the loop (planner=True)")
    with ExitStack() as stack:
        built = _build(cfg, duration, stack, hooks)
        outcome = _drive(built, duration)
        report = _report(cfg, built, outcome)
        if cfg.picture is not None:
            from sim.render import render_picture  # noqa: PLC0415 - rendering is optional

            render_picture(built.robot.model, built.robot.data, cfg.picture)
            report["picture"] = str(cfg.picture)
        if built.recorder is not None:
            report["video"] = str(cfg.video)
    report |= built.session.recorder_report()  # after closing: the file is finished
    hw = built.session.backend.report()  # after closing: the counters include the damped shutdown
    if hw is not None:
        report["hw"] = hw
        if cfg.faults is not None:
            plan = load_fault_file(cfg.faults)
            report["drill"] = judge_drill(plan, cfg.faults, hw, report["falls"] > 0, report["damp_reason"], report)
    _write_outputs(cfg, built.session, report)
    if outcome.error is not None:
        where = f"; report: {cfg.report}" if cfg.report else ""
        raise RunAborted(f"run aborted after {report['sim_seconds']} s: {outcome.error}{where}") from outcome.error
    return report


def _build(cfg: SimRunConfig, duration: float | None, stack: ExitStack, hooks: RunHooks | None = None) -> _BuiltRun:
    """The G1 in MuJoCo, the tracker by name, the backend, the input and the outputs; all closed by `stack`."""
    assets = ensure_assets(cfg.assets_dir)
    ground = cfg.perturbations.terrain_height_m if cfg.perturbations is not None else 0.0
    robot = SimRobot(build_model(assets.g1_mjcf, SceneConfig(terrain_height=ground, terrain_seed=cfg.seed)))
    stack.callback(robot.close)
    tracker_name = cfg.tracker or ("decoupled" if cfg.planner else "velocity")
    tracker = make_tracker(tracker_name, TrackerSpec(cfg.policy, assets, robot.joint_names))
    if tracker.needs_plan and not cfg.planner:
        raise ConfigError(f"the {tracker.name} tracker follows planned whole-body motion: add --planner")
    backend = _backend(cfg, robot, duration)
    stack.callback(backend.close)
    source = stack.enter_context(open_input(cfg.input, tracker.command_limits, cfg.scenario, duration or 0.0, cfg.seed, cfg.hardware))
    wall_paced = backend.paced_on_wall_clock  # a robot in another process: its time is the wall's
    realtime = cfg.realtime or cfg.input != "scripted" or cfg.viewer or wall_paced
    clock = (RealtimeSimulationClock if realtime and not wall_paced else SimulationClock)(backend.now, backend.advance_to)
    recorder = viewer = None
    if cfg.video is not None:
        from sim.render import VideoRecorder  # noqa: PLC0415 - rendering is optional

        recorder = stack.enter_context(VideoRecorder(robot.model, cfg.video, fps=cfg.video_fps))
    if cfg.viewer:
        from sim.render import open_viewer  # noqa: PLC0415 - needs a display

        viewer = stack.enter_context(open_viewer(robot.model, robot.data))
    total = round(duration * tracker.rate_hz) if duration else None
    bar = stack.enter_context(tqdm(total=total, unit="tick", disable=not cfg.progress, desc=f"sim {cfg.scenario}", file=sys.stderr))
    from controller.reference.waypoints import WaypointFollower, WaypointReference  # noqa: PLC0415

    reference: ReferenceSource | None = None
    waypoints = load_scenario(cfg.scenario).waypoints if cfg.input == "scripted" else ()
    follower = WaypointFollower(waypoints, limits=tracker.command_limits) if waypoints else None
    if cfg.planner:
        from controller.planner.runtime import Planner  # noqa: PLC0415 - onnxruntime session of the planner
        from controller.reference.planned import PlannedReference  # noqa: PLC0415

        planner = Planner.load()
        planner.warm_up()
        planned = PlannedReference(
            planner.plan, simulated_clock=not realtime, joint_limits=robot.joint_limits(), seed=cfg.seed, follower=follower
        )
        stack.callback(planned.close)
        # The truth is the simulated robot here, on every backend (the DDS G1's mirror too), the simulator directly included.
        reference = planned if hooks is None else hooks.wrap_reference(planned, tracker.command_limits, robot.read)
    elif follower is not None:
        reference = WaypointReference(follower)
    estimated = attach_estimator(backend, cfg.estimator, cfg.estimator_config, cfg.assets_dir)
    session = Session(backend, tracker, source, reference, estimated, cfg.record)
    stack.callback(session.close)
    ghost = None
    if viewer is not None and reference is not None:
        from sim.render import Ghost  # noqa: PLC0415

        ghost = Ghost(robot.model)
    status = None
    if cfg.status:
        status = StatusLine(sys.stderr)
        stack.callback(status.close)
    return _BuiltRun(robot, session, RateLoop(clock, tracker.rate_hz), recorder, viewer, bar, ghost, status, hooks)


def _backend(cfg: SimRunConfig, robot: SimRobot, duration: float | None) -> Backend:
    """MuJoCo directly, simulated buses with MuJoCo behind them, or the simulated G1 in its own process over DDS."""
    hardware = load_robot_config(cfg.hardware) if cfg.hardware is not None else None
    if cfg.perturbations is not None:
        if isinstance(hardware, DdsHardwareConfig):
            raise ConfigError("--perturb needs the physics in this process: the simulator, or simulated buses (sim-can, sim-mixed)")
        apply_to_model(robot.model, cfg.perturbations)
        if cfg.hardware is None:
            return PerturbedSimBackend(robot, cfg.perturbations, duration or 0.0, cfg.seed)
        return SimulatedHardwareBackend(robot, cfg.hardware, cfg.faults, cfg.perturbations, duration or 0.0, cfg.seed)
    if cfg.hardware is None:
        return DirectSimBackend(robot)
    if isinstance(hardware, DdsHardwareConfig):
        from controller.runtime.dds_backend import SimulatedDdsBackend  # noqa: PLC0415 - the g1 extra

        remote = ("--remote", cfg.scenario) if cfg.input == "unitree-remote" else ()  # the robot's remote plays the scenario
        faults = load_fault_file(cfg.faults).robot if cfg.faults is not None else ()
        drills = tuple(arg for fault in faults for arg in ("--fault", fault))
        robot_args = (*remote, *drills, "--joint-map", cfg.hardware, "--seed", str(cfg.seed))
        return SimulatedDdsBackend(robot, hardware, cfg.hardware, cfg.assets_dir, robot_args)
    return SimulatedHardwareBackend(robot, cfg.hardware, cfg.faults, seed=cfg.seed)


def _drive(run: _BuiltRun, duration: float | None) -> _Outcome:
    """Bring the backend up and tick until the end, a fall that ends the run, a fault at bring-up, Ctrl-C or an exception."""
    session = run.session
    hooks = run.hooks
    caption = hooks.caption if hooks is not None else None
    done = hooks.done if hooks is not None else None
    interrupted, error = False, None
    wall_start = time.perf_counter()
    try:
        session.start()
        for tick in run.loop.run(duration):
            going_on = session.tick()
            window = session.last_window
            ghost = window.plan.qpos if window is not None and window.plan is not None else None
            if run.recorder is not None:
                run.recorder.maybe_capture(run.robot.data, ghost, caption() if caption is not None else None)
            if run.viewer is not None:
                _sync_viewer(run.viewer, run.ghost, ghost)
            if run.status is not None:
                run.status.update(session, caption() if caption is not None else "")
            if tick % 10 == 9:
                run.bar.update(10)
            if not going_on or (done is not None and done()):
                break
    except (HardwareFault, MotorNotFoundError) as exc:  # bring-up failed: the robot damps, the run ends as a fault
        session.fail(str(exc))
    except KeyboardInterrupt:
        interrupted = True
    except Exception as exc:  # reported, then raised again: the run fails loudly
        error = exc
    return _Outcome(time.perf_counter() - wall_start, interrupted, error)


def _sync_viewer(viewer: Any, ghost: Any, qpos: Any) -> None:
    """Show the new physics state, with the plan's pose as a ghost when there is one."""
    if ghost is not None and qpos is not None:
        with viewer.lock():
            viewer.user_scn.ngeom = 0
            ghost.add_to(viewer.user_scn, qpos)
    viewer.sync()


def _report(cfg: SimRunConfig, run: _BuiltRun, outcome: _Outcome) -> dict[str, Any]:
    report: dict[str, Any] = {"scenario": cfg.scenario if cfg.input == "scripted" else cfg.input, "policy": cfg.policy, "seed": cfg.seed}
    report |= run.session.report()
    wall = outcome.wall_seconds
    report["wall_seconds"] = round(wall, 4)
    report["real_time_factor"] = round(report["sim_seconds"] / wall, 3) if wall > 0 else None
    report["overruns"] = run.loop.overruns
    report["final_base_position"] = [round(float(v), 4) for v in run.robot.read().base_pos]
    report["interrupted"] = outcome.interrupted
    backend = run.session.backend
    if cfg.perturbations is not None and isinstance(backend, PerturbedSimBackend | SimulatedHardwareBackend):
        report["perturbations"] = dataclasses.asdict(cfg.perturbations)
        report["pushes"] = [{"start": push.start, "force_n": [round(f, 3) for f in push.force]} for push in backend.pushes.pushes]
        report["push_impulse_ns"] = cfg.perturbations.pushes.impulse_ns if cfg.perturbations.pushes is not None else 0.0
    if outcome.error is not None:
        report["error"] = f"{type(outcome.error).__name__}: {outcome.error}"
    return report


def _write_outputs(cfg: SimRunConfig, session: Session, report: dict[str, Any]) -> None:
    plot_path = cfg.plot or (cfg.report.with_suffix(".png") if cfg.report else None)
    if plot_path is not None:  # also after a fault or an error: what was tracked until then
        damp_time = report["damp_time"]
        damped = (session.start_time + damp_time, report["damp_reason"]) if damp_time is not None else None
        title = f"{report['scenario']} / {cfg.policy}: commanded vs measured"
        plot_tracking(session.metrics, plot_path, title, damped, session.plan_metrics)
        report["plot"] = str(plot_path)
    if cfg.report is not None:
        write_report(report, cfg.report)
