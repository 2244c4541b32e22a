"""`g1ctl sim`: run a command scenario on the simulated G1 and report how well it tracked.

This module imports MuJoCo (through `sim`); hardware runs never import it.
"""

from __future__ import annotations

import json
import sys
import time
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from controller.assets import ensure_assets
from controller.inputs.base import CommandLimits, CommandSource
from controller.inputs.scripted import ScriptedSource, load_scenario, timeline
from controller.runtime.loop import RateLoop, RealtimeSimulationClock, SimulationClock
from controller.runtime.tracking_metrics import TrackingMetrics, percentiles_ms
from controller.runtime.plots import plot_tracking
from controller.tracking.presets import load_policy
from controller.runtime.sim_backends import DirectBackend, HardwareBackend
from controller.runtime.supervisor import Mode, Supervisor
from hw.errors import ConfigError
from hw.jointmap import load_hardware_config
from sim.robot import SimRobot
from sim.world import build_model

INPUTS = ("scripted", "keyboard", "gamepad")


@dataclass(frozen=True)
class SimRunConfig:
    scenario: str = "walk_turn_stop"
    policy: str = "fastsac"
    duration: float | None = None  # None: the scenario's duration
    seed: int = 0
    input: str = "scripted"
    video: Path | None = None
    report: Path | None = None
    plot: Path | None = None  # None: beside the report, as .png
    realtime: bool = False
    viewer: bool = False
    progress: bool = False
    assets_dir: str | None = None
    video_fps: int = 20
    hardware: str | None = None  # a hardware config: drive the sim through its codecs and buses
    faults: str | None = None  # with `hardware`: a YAML of faults to inject per bus
    picture: Path | None = None  # PNG of the final frame


def make_source(cfg: SimRunConfig, limits: CommandLimits, duration: float) -> CommandSource:
    """The command source of the run: a scenario's timeline, the keyboard or a gamepad."""
    if cfg.input == "scripted":
        return ScriptedSource(timeline(load_scenario(cfg.scenario), duration, limits, cfg.seed), limits)
    if cfg.input == "keyboard":
        from controller.inputs.keyboard import HELP, KeyboardSource  # noqa: PLC0415

        print(HELP, file=sys.stderr)
        return KeyboardSource(limits)
    if cfg.input == "gamepad":
        from controller.inputs.gamepad import GamepadConfig, GamepadSource  # noqa: PLC0415

        return GamepadSource(GamepadConfig(), limits)
    raise ConfigError(f"unknown input '{cfg.input}' (valid: {', '.join(INPUTS)})")


def run(cfg: SimRunConfig) -> dict[str, Any]:
    """Run the scenario and return the report (also written to `cfg.report` when set)."""
    scenario = load_scenario(cfg.scenario) if cfg.input == "scripted" else None
    assets = ensure_assets(cfg.assets_dir)
    robot = SimRobot(build_model(assets.g1_mjcf))
    policy = load_policy(cfg.policy, assets, robot.joint_names)
    if cfg.hardware is not None:
        load_hardware_config(cfg.hardware)  # a bad config is a user error before anything starts
    elif cfg.faults is not None:
        raise ConfigError("--faults needs --hardware: faults are injected into simulated hardware")
    interactive = cfg.input != "scripted"
    duration = cfg.duration if cfg.duration is not None else (scenario.duration if scenario else None)
    if duration is not None and duration <= 0:
        raise ConfigError(f"--duration must be positive, got {duration}")
    realtime = cfg.realtime or interactive or cfg.viewer
    backend: DirectBackend | HardwareBackend = (
        DirectBackend(robot) if cfg.hardware is None else HardwareBackend(robot, cfg.hardware, cfg.faults)
    )
    clock = (RealtimeSimulationClock if realtime else SimulationClock)(lambda: robot.time, backend.advance_to)
    loop = RateLoop(clock, policy.cfg.rate_hz)
    controlled = backend.robot
    supervisor = Supervisor()
    metrics = TrackingMetrics()
    step_times: list[float] = []
    falls: list[float] = []
    recorder = None
    interrupted = False

    with ExitStack() as stack:
        stack.callback(backend.close)
        source = make_source(cfg, policy.command_limits, duration or 0.0)
        stack.enter_context(source)
        if cfg.video is not None:
            from sim.render import VideoRecorder  # noqa: PLC0415 - rendering is optional

            recorder = stack.enter_context(VideoRecorder(robot.model, cfg.video, fps=cfg.video_fps))
        viewer = _open_viewer(robot, stack) if cfg.viewer else None
        total = round(duration * policy.cfg.rate_hz) if duration else None
        bar = stack.enter_context(tqdm(total=total, unit="tick", disable=not cfg.progress, desc=f"sim {cfg.scenario}", file=sys.stderr))
        wall_start = time.perf_counter()
        sim_start = robot.time
        try:
            for tick in loop.run(duration):
                truth = robot.read() if controlled is not robot else None
                state = controlled.read()
                sample = source.poll(state.time)
                velocity = supervisor.update(sample, policy.latched_fault or backend.fault())
                measured = truth or state  # metrics use the simulator's ground truth
                metrics.record(measured.time, measured.base_pos, measured.base_quat, velocity)
                t0 = time.perf_counter()
                command = policy.damping_command() if supervisor.mode is Mode.DAMP else policy.step(state, velocity)
                step_times.append(time.perf_counter() - t0)
                controlled.write(command)
                if recorder is not None:
                    recorder.maybe_capture(robot.data)
                if viewer is not None:
                    viewer.sync()
                if robot.has_fallen():
                    falls.append(round(state.time - sim_start, 3))
                    if supervisor.mode is Mode.DAMP or not backend.recover_from_fall():
                        break  # damped on purpose, or on hardware: nothing left to run
                    policy.reset()
                    metrics.reset_reference()
                if tick % 10 == 9:
                    bar.update(10)
        except KeyboardInterrupt:
            interrupted = True
        wall = time.perf_counter() - wall_start
        sim_seconds = robot.time - sim_start
        final_pos = robot.read().base_pos
        if cfg.picture is not None:
            from sim.render import render_picture  # noqa: PLC0415 - rendering is optional

            render_picture(robot.model, robot.data, cfg.picture)

    report: dict[str, Any] = {
        "scenario": cfg.scenario if scenario else cfg.input,
        "policy": cfg.policy,
        "seed": cfg.seed,
        "sim_seconds": round(sim_seconds, 4),
        "wall_seconds": round(wall, 4),
        "real_time_factor": round(sim_seconds / wall, 3) if wall > 0 else None,
        "falls": len(falls),
        "fall_times": falls,
        "velocity_error_mean": round(metrics.velocity_error_mean, 4),
        "yaw_rate_error_mean": round(metrics.yaw_rate_error_mean, 4),
        "policy_step_ms": percentiles_ms(step_times),
        "overruns": loop.overruns,
        "nonfinite_actions": policy.nonfinite_events,
        "final_mode": supervisor.mode.value,
        "damp_reason": supervisor.damp_reason,
        "estops": supervisor.estops,
        "input_losses": supervisor.input_losses,
        "final_base_position": [round(float(v), 4) for v in final_pos],
        "interrupted": interrupted,
    }
    hw_report = backend.report()
    if hw_report is not None:
        report["hw"] = hw_report
    if recorder is not None:
        report["video"] = str(cfg.video)
    if cfg.picture is not None:
        report["picture"] = str(cfg.picture)
    plot_path = cfg.plot or (cfg.report.with_suffix(".png") if cfg.report else None)
    if plot_path is not None and metrics.times:
        plot_tracking(metrics, plot_path, f"{report['scenario']} / {cfg.policy}: commanded vs measured")
        report["plot"] = str(plot_path)
    if cfg.report is not None:
        cfg.report.parent.mkdir(parents=True, exist_ok=True)
        cfg.report.write_text(json.dumps(report, indent=2) + "\n")
    return report


def _open_viewer(robot: SimRobot, stack: ExitStack) -> Any:
    import mujoco.viewer  # noqa: PLC0415 - needs a display

    try:
        return stack.enter_context(mujoco.viewer.launch_passive(robot.model, robot.data))
    except Exception as exc:  # GLFW raises plain RuntimeError without a display
        raise ConfigError(f"cannot open the MuJoCo viewer ({exc}); it needs a display: drop --viewer or use --video") from exc
