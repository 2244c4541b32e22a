"""The run driver: one run built from its plan, driven to its end and reported, on the simulator or a robot alike.

`run(cfg)` resolves the config into the plan of the run (`run_plan.resolve_run`); `execute(plan)`
builds the run from it: the tracker by name, the backend from the registry (`backend_registry`),
the input, the reference (the command, waypoints, or the planner in the loop), the state
estimator where the plan puts one, the outputs. It ticks the session at the tracker's rate on
the plan's clock: simulated time (as fast as it goes, or held to the wall clock), or the wall
clock of a robot that runs on its own. Whatever ends the run (the end of the input, a fault, a
fall on hardware, Ctrl-C, an exception), the JSON report and its plot are written, and an
exception is raised again as `RunAborted` once they are. A simulator and a robot differ only in
what the registry builds and in the clock. Nothing here imports MuJoCo: the simulator's builders
do, and the video, picture and viewer when asked for.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from contextlib import ExitStack
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from tqdm import tqdm

from controller.assets import ensure_assets
from controller.estimation.step import load_compiled
from controller.inputs.registry import open_input
from controller.planner.process import planner_cpu
from controller.reports import write_report
from controller.runtime.backend_registry import BuiltBackend
from controller.runtime.estimation import attach_estimator
from controller.runtime.loop import RateLoop, RealtimeSimulationClock, SimulationClock
from controller.runtime.run_config import RunConfig, RunHooks
from controller.runtime.run_plan import RunPlan, resolve_run
from controller.runtime.session import Session
from controller.runtime.status import StatusLine
from controller.tracking.registry import TrackerSpec, make_tracker
from hw import g1
from hw.emulation.drill import judge_drill
from hw.errors import ConfigError, HardwareFault, MotorNotFoundError, RunAborted
from hw.realtime import Scheduling, request_realtime

if TYPE_CHECKING:
    from collections.abc import Callable
    from concurrent.futures import Future

    from controller.commands.velocity import CommandLimits
    from controller.planner.request import Plan, PlanRequest
    from controller.reference.source import ReferenceSource
    from sim.robot import SimRobot


@dataclass
class BuiltRun:
    """A run ready to go: its plan, the robot side, the session on its backend, the loop and the outputs."""

    plan: RunPlan
    robot_side: BuiltBackend
    session: Session
    loop: RateLoop
    scheduling: Scheduling
    bar: tqdm[Any]
    recorder: Any = None  # sim.render.VideoRecorder, when a video is asked for
    viewer: Any = None  # MuJoCo's passive viewer, with --viewer
    ghost: Any = None  # sim.render.Ghost drawing the plan in the viewer
    status: StatusLine | None = None
    hooks: RunHooks | None = None


@dataclass(frozen=True)
class Outcome:
    wall_seconds: float
    interrupted: bool
    error: Exception | None


def run(cfg: RunConfig, hooks: RunHooks | None = None) -> dict[str, Any]:
    """Resolve `cfg` into the plan of its run, then `execute` it."""
    return execute(resolve_run(cfg), hooks)


def execute(plan: RunPlan, hooks: RunHooks | None = None) -> dict[str, Any]:
    """Build, drive and report the run; the report is also written to `plan.outputs.report` when set.

    Raises `RunAborted` (after writing the report) when an exception ended the run.
    """
    if hooks is not None and not plan.planner:
        raise ConfigError("this run plans whole-body motion: it needs the planner in the loop (planner=True)")
    with ExitStack() as stack:
        built = build(plan, stack, hooks)
        outcome = drive(built)
        report = _report(built, outcome)
        if plan.outputs.picture is not None:
            from sim.render import render_picture  # noqa: PLC0415 - rendering is optional

            world = _world(built.robot_side)
            render_picture(world.model, world.data, plan.outputs.picture)
            report["picture"] = str(plan.outputs.picture)
        if built.recorder is not None:
            report["video"] = str(plan.outputs.video)
    report |= built.session.recorder_report()  # after closing: the recording is finished
    hw = built.session.backend.report()  # after closing: the counters include the damped shutdown
    if hw is not None:
        report["hw"] = hw
        if plan.faults is not None and plan.faults_name is not None:
            report["drill"] = judge_drill(plan.faults, plan.faults_name, hw, report["falls"] > 0, report["damp_reason"], report)
    _write_outputs(plan, built.session, report)
    if outcome.error is not None:
        where = f"; report: {plan.outputs.report}" if plan.outputs.report else ""
        raise RunAborted(f"run aborted after {report['run_seconds']} s: {outcome.error}{where}") from outcome.error
    return report


def build(plan: RunPlan, stack: ExitStack, hooks: RunHooks | None = None) -> BuiltRun:
    """The tracker, the robot side from the registry, the input, the reference, the estimator and the outputs; all closed
    by `stack`."""
    assets = ensure_assets(plan.assets_dir)
    tracker = make_tracker(plan.tracker, TrackerSpec(plan.policy, assets, g1.JOINT_NAMES))
    cpus = os.sched_getaffinity(0)  # before the loop may be pinned to one of them
    scheduling = request_realtime(plan.rt_priority, plan.cpu)  # before the robot side starts its threads: they inherit it
    if plan.estimator:
        load_compiled()  # the estimator's compiled step, before a robot that runs on its own is started (seconds on a first run)
    side = plan.backend.builder()(plan, assets, stack)
    backend = side.backend
    instructions = hooks.instructions if hooks is not None else None
    source = stack.enter_context(
        open_input(plan.input, tracker.command_limits, plan.scenario, plan.duration or 0.0, plan.seed, side.remote_dds, instructions)
    )
    # Simulated time moves as the loop sleeps; a robot that runs on its own moves on the wall clock as its backend waits.
    clock = (RealtimeSimulationClock if plan.clock == "simulated-realtime" else SimulationClock)(backend.now, backend.advance_to)
    outputs = plan.outputs
    recorder = viewer = None
    if outputs.video is not None:
        from sim.render import VideoRecorder  # noqa: PLC0415 - rendering is optional

        recorder = stack.enter_context(VideoRecorder(_world(side).model, outputs.video, fps=outputs.video_fps))
    if outputs.viewer:
        from sim.render import open_viewer  # noqa: PLC0415 - needs a display

        viewer = stack.enter_context(open_viewer(_world(side).model, _world(side).data))
    total = round(plan.duration * tracker.rate_hz) if plan.duration else None
    desc = f"{plan.backend.name} {plan.scenario_name if plan.input == 'scripted' else plan.input}"
    bar = stack.enter_context(tqdm(total=total, unit="tick", disable=not outputs.progress, desc=desc, file=sys.stderr))
    reference = _reference(plan, side, tracker.command_limits, stack, hooks, planner_cpu(cpus, plan.cpu))
    session = Session(backend, tracker, source, reference, attach_estimator(backend, plan), outputs.record)
    stack.callback(session.close)
    ghost = None
    if viewer is not None and reference is not None:
        from sim.render import Ghost  # noqa: PLC0415

        ghost = Ghost(_world(side).model)
    status = None
    if outputs.status:
        status = StatusLine(sys.stderr)
        stack.callback(status.close)
    loop = RateLoop(clock, tracker.rate_hz)
    return BuiltRun(plan, side, session, loop, scheduling, bar, recorder, viewer, ghost, status, hooks)


def _reference(
    plan: RunPlan, side: BuiltBackend, limits: CommandLimits, stack: ExitStack, hooks: RunHooks | None, cpu: int | None
) -> ReferenceSource | None:
    """The scenario's waypoints, the planner in the loop (a job's reference over it), or None: the command alone. On the
    wall clock the planner runs in a process of its own, on `cpu` where there is one."""
    from controller.reference.waypoints import WaypointFollower, WaypointReference  # noqa: PLC0415

    waypoints = plan.scenario.waypoints if plan.scenario is not None else ()
    follower = WaypointFollower(waypoints, limits=limits) if waypoints else None
    if not plan.planner:
        return WaypointReference(follower) if follower is not None else None
    from controller.reference.planned import PlannedReference  # noqa: PLC0415

    simulated = plan.clock == "simulated"
    plan_fn, submit = _planner(simulated, stack, cpu)
    planned = PlannedReference(
        plan_fn, simulated_clock=simulated, joint_limits=side.joint_limits, seed=plan.seed, follower=follower, submit=submit
    )
    stack.callback(planned.close)
    if hooks is None:
        return planned
    # A job judges by the simulator's truth where one stands behind the robot (the DDS G1's mirror too), else by nothing.
    truth = side.world.read if side.world is not None else side.backend.truth
    wrapped = hooks.wrap_reference(planned, limits, truth)
    stack.callback(wrapped.close)
    return wrapped


def _planner(
    simulated_clock: bool, stack: ExitStack, cpu: int | None
) -> tuple[Callable[[PlanRequest], Plan], Callable[[PlanRequest], Future[Plan]] | None]:
    """The planner's `plan` warmed up, and its `submit` where it has one: in this process on the simulated clock (the loop
    waits for each plan, nothing competes), in a process of its own on the wall clock, asked from the tick's thread (a plan
    beside the loop would share its interpreter lock, and a worker thread would have to be handed it to start one)."""
    if simulated_clock:
        from controller.planner.runtime import Planner  # noqa: PLC0415 - onnxruntime session of the planner

        planner = Planner.load()
        planner.warm_up()
        return planner.plan, None
    from controller.planner.process import REPLY_SWITCH_INTERVAL_S, PlannerProcess  # noqa: PLC0415

    process = stack.enter_context(PlannerProcess(cpu=cpu))
    stack.callback(sys.setswitchinterval, sys.getswitchinterval())
    sys.setswitchinterval(REPLY_SWITCH_INTERVAL_S)
    return process.plan, process.submit


def _world(side: BuiltBackend) -> SimRobot:
    if side.world is None:  # the plan refuses these on a robot with no simulator behind it
        raise ConfigError("a video, a picture and the viewer need the simulator")
    return side.world


def drive(run: BuiltRun) -> Outcome:
    """Bring the backend up and tick until the end, a fall that ends the run, a fault, Ctrl-C or an exception."""
    session = run.session
    caption = run.hooks.caption if run.hooks is not None else None
    done = run.hooks.done if run.hooks is not None else None
    said = run.hooks.log if run.hooks is not None else None
    interrupted, error = False, None
    wall_start = time.perf_counter()
    try:
        session.start()
        for tick in run.loop.run(run.plan.duration):
            going_on = session.tick()
            _show(run, caption() if caption is not None else None)
            if said is not None:
                _note(session, said())
            if tick % 10 == 9:
                run.bar.update(10)
            if not going_on or (done is not None and done()):
                break
    except (HardwareFault, MotorNotFoundError) as exc:  # the robot side failed (bring-up, a motor gone): it damps, a fault ends the run
        session.fail(str(exc))
    except KeyboardInterrupt:
        interrupted = True
    except Exception as exc:  # reported, then raised again: the run fails loudly
        error = exc
    return Outcome(time.perf_counter() - wall_start, interrupted, error)


def _show(run: BuiltRun, caption: str | None) -> None:
    """The tick on the video, the viewer and the status line, as far as there are any."""
    window = run.session.last_window
    ghost = window.plan.qpos if window is not None and window.plan is not None else None
    if run.recorder is not None:
        run.recorder.maybe_capture(_world(run.robot_side).data, ghost, caption)
    if run.viewer is not None:
        _sync_viewer(run.viewer, run.ghost, ghost)
    if run.status is not None:
        run.status.update(run.session, caption or "")


def _note(session: Session, lines: list[str]) -> None:
    """A job's lines (instructions accepted, refused) into the flight recorder's log, when the run records."""
    if lines and session.recorder is not None:
        from controller.recording.recorder import INFO  # noqa: PLC0415 - the recorder is loaded when recording

        for line in lines:
            session.recorder.note("instructions", line, INFO)


def _sync_viewer(viewer: Any, ghost: Any, qpos: Any) -> None:
    """Show the new physics state, with the plan's pose as a ghost when there is one."""
    if ghost is not None and qpos is not None:
        with viewer.lock():
            viewer.user_scn.ngeom = 0
            ghost.add_to(viewer.user_scn, qpos)
    viewer.sync()


def _report(run: BuiltRun, outcome: Outcome) -> dict[str, Any]:
    plan = run.plan
    report: dict[str, Any] = {
        "scenario": plan.scenario_name if plan.input == "scripted" else plan.input,
        "input": plan.input,
        "policy": plan.policy,
        "seed": plan.seed,
        "backend": plan.backend.name,
        "hardware": plan.hardware_name,
    }
    report |= run.session.report()
    wall = outcome.wall_seconds
    report["wall_seconds"] = round(wall, 4)
    if plan.backend.simulated:
        report["real_time_factor"] = round(report["run_seconds"] / wall, 3) if wall > 0 else None
    report["overruns"] = run.loop.overruns
    world = run.robot_side.world
    if world is not None:  # the simulator's truth
        report["final_base_position"] = [round(float(v), 4) for v in world.read().base_pos]
    report["interrupted"] = outcome.interrupted
    report["scheduling"] = run.scheduling.describe()
    pushes = run.robot_side.pushes
    if plan.perturbations is not None and pushes is not None:
        report["perturbations"] = dataclasses.asdict(plan.perturbations)
        report["pushes"] = [{"start": push.start, "force_n": [round(f, 3) for f in push.force]} for push in pushes.pushes]
        report["push_impulse_ns"] = plan.perturbations.pushes.impulse_ns if plan.perturbations.pushes is not None else 0.0
    if outcome.error is not None:
        report["error"] = f"{type(outcome.error).__name__}: {outcome.error}"
    return report


def _write_outputs(plan: RunPlan, session: Session, report: dict[str, Any]) -> None:
    plot_path = plan.outputs.plot
    if plot_path is not None:  # also after a fault or an error: what was tracked until then
        from controller.runtime.plots import plot_tracking  # noqa: PLC0415 - matplotlib, only for a plot

        damp_time = report["damp_time"]
        damped = (session.start_time + damp_time, report["damp_reason"]) if damp_time is not None else None
        title = f"{report['scenario']} / {plan.policy}: commanded vs measured"
        plot_tracking(session.metrics, plot_path, title, damped, session.plan_metrics)
        report["plot"] = str(plot_path)
    if plan.outputs.report is not None:
        write_report(report, plan.outputs.report)
