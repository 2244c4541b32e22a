"""`g1ctl run --hardware g1-dds`: the whole stack on a real G1 over its DDS topics, no simulator.

The same session, trackers, inputs and planner as `g1ctl sim`; the backend is the robot itself
(`DdsBackend`: its lifecycle, the 500 Hz cycle on the wall clock, latched damping on any
fault). Nothing here imports MuJoCo: the joint limits the planner keeps to come from the
hardware config. There is no ground truth on a robot, so the report gives what the robot
measures (the commanded and measured yaw rate, faults, counters, the state at the end); a
fall is the pelvis tilted past 60 degrees by the IMU, and ends the run damped. A job built on a run (the
text planner) comes in through the same `RunHooks` as on the simulator: its reference over the planned one,
its caption on the status line (there is no video), its early end.
"""

from __future__ import annotations

import math
import sys
import time
from contextlib import ExitStack
from typing import TYPE_CHECKING, Any

import numpy as np

from controller.assets import ensure_assets
from controller.inputs.registry import open_input
from controller.inputs.scripted import load_scenario
from controller.reports import write_report
from controller.runtime.dds_backend import DdsBackend
from controller.runtime.estimation import attach_estimator
from controller.runtime.loop import RateLoop, RunClock, SimulationClock
from controller.runtime.run_config import RunHooks, SimRunConfig
from controller.runtime.session import Session
from controller.runtime.status import StatusLine
from controller.tracking.registry import TrackerSpec, make_tracker
from hw import g1, quat
from hw.dds.config import DdsHardwareConfig
from hw.dds.robot import DdsRobot
from hw.errors import ConfigError, HardwareFault, RunAborted
from hw.jointmap import load_robot_config
from hw.realtime import request_realtime

if TYPE_CHECKING:
    from controller.reference.source import ReferenceSource

MAX_TILT_DEG = 60.0  # the simulator's fall threshold (`sim.robot.FallConfig`), from the IMU here


class RobotBackend(DdsBackend):
    """A real G1: no ground truth; a fall is the IMU's pelvis tilt past `MAX_TILT_DEG`."""

    def has_fallen(self) -> bool:
        up_z = float(quat.rotate(self.host.read().base_quat, np.array([0.0, 0.0, 1.0]))[2])
        return up_z < math.cos(math.radians(MAX_TILT_DEG))


def robot_config(cfg: SimRunConfig) -> DdsHardwareConfig:
    """The real robot's config, and one line for each option a robot cannot honour."""
    hardware = load_robot_config(str(cfg.hardware))
    if not isinstance(hardware, DdsHardwareConfig) or hardware.simulated:
        raise ConfigError(f"hardware config '{cfg.hardware}' is not a real G1 over DDS")
    unsupported = [name for name, given in (("--video", cfg.video), ("--picture", cfg.picture), ("--viewer", cfg.viewer)) if given]
    if unsupported or cfg.faults:
        raise ConfigError(f"{', '.join(unsupported or ['--faults'])}: not on a real robot (they need the simulator)")
    return hardware


def run(cfg: SimRunConfig, hooks: RunHooks | None = None) -> dict[str, Any]:
    """Bring the robot up, run the input until its end (or Ctrl-C, a fault, a fall, the job's `hooks.done()`), damp, report."""
    hardware = robot_config(cfg)
    if hooks is not None and not cfg.planner:
        raise ConfigError("this run plans whole-body motion: it needs the planner in the loop (planner=True)")
    scenario = load_scenario(cfg.scenario) if cfg.input == "scripted" else None
    duration = cfg.duration if cfg.duration is not None else (scenario.duration if scenario else None)
    assets = ensure_assets(cfg.assets_dir)
    tracker = make_tracker(cfg.tracker or ("decoupled" if cfg.planner else "velocity"), TrackerSpec(cfg.policy, assets, g1.JOINT_NAMES))
    if tracker.needs_plan and not cfg.planner:
        raise ConfigError(f"the {tracker.name} tracker follows planned whole-body motion: add --planner")
    scheduling = request_realtime(cfg.rt_priority, cfg.cpu)  # before any thread starts: they inherit it
    clock = RunClock()
    error: Exception | None = None
    interrupted = False
    with ExitStack() as stack:
        backend = stack.enter_context(RobotBackend(DdsRobot(hardware, clock=clock.now), str(cfg.hardware), clock))
        source = stack.enter_context(
            open_input(cfg.input, tracker.command_limits, cfg.scenario, duration or 0.0, cfg.seed, hardware=cfg.hardware)
        )
        reference: ReferenceSource | None = None
        if cfg.planner:
            from controller.planner.runtime import Planner  # noqa: PLC0415 - onnxruntime session of the planner
            from controller.reference.planned import PlannedReference  # noqa: PLC0415

            planner = Planner.load()
            planner.warm_up()
            limits = np.array([hardware.joints[name].position_limits for name in g1.JOINT_NAMES])
            planned = PlannedReference(planner.plan, simulated_clock=False, joint_limits=(limits[:, 0], limits[:, 1]), seed=cfg.seed)
            stack.callback(planned.close)
            reference = planned if hooks is None else hooks.wrap_reference(planned, tracker.command_limits, backend.truth)
        estimated = attach_estimator(backend, cfg.estimator, cfg.estimator_config, cfg.assets_dir)  # a robot: always
        session = Session(backend, tracker, source, reference, estimated, cfg.record)
        stack.callback(session.close)
        status = StatusLine(sys.stderr) if cfg.status else None
        loop = RateLoop(SimulationClock(backend.now, backend.advance_to), tracker.rate_hz)
        caption = hooks.caption if hooks is not None else None
        done = hooks.done if hooks is not None else None
        wall_start = time.perf_counter()
        try:
            session.start()
            for _ in loop.run(duration):
                going_on = session.tick()
                if status is not None:
                    status.update(session, caption() if caption is not None else "")
                if not going_on or (done is not None and done()):
                    break
        except HardwareFault as exc:  # bring-up failed: the robot damps, the run ends as a fault
            session.fail(str(exc))
        except KeyboardInterrupt:
            interrupted = True
        except Exception as exc:  # reported, then raised again: the run fails loudly
            error = exc
        finally:
            if status is not None:
                status.close()
        report: dict[str, Any] = {"robot": str(cfg.hardware), "input": cfg.input, "policy": cfg.policy, "seed": cfg.seed}
        report |= session.report()
        report |= {"wall_seconds": round(time.perf_counter() - wall_start, 4), "overruns": loop.overruns, "interrupted": interrupted}
        report["scheduling"] = scheduling.describe()
        if error is not None:
            report["error"] = f"{type(error).__name__}: {error}"
    report["hw"] = backend.report()  # after closing: the counters include the damped shutdown
    report |= session.recorder_report()  # after closing: the file is finished
    if cfg.report is not None:
        write_report(report, cfg.report)
    if error is not None:
        raise RunAborted(f"run aborted after {report['sim_seconds']} s: {error}") from error
    return report
