"""The session: one control tick shared by every backend, and the run's report.

A tick reads the robot, polls the command input, lets the supervisor decide the mode,
asks the tracker for a joint command on the reference window (or damps) and writes it.
The session imports no simulator: the same tick drives MuJoCo, simulated hardware and
real hardware through a `Backend`.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from controller.commands.velocity import VelocityCommand
from controller.inputs.base import CommandSource
from controller.recording.tick import Tick
from controller.reference.source import CommandReference, ReferenceSource
from controller.reference.window import ReferenceWindow
from controller.reports import percentiles_ms
from controller.runtime.backend import Backend
from controller.runtime.estimation import EstimatedRobot, EstimateJudge
from controller.runtime.supervisor import Mode, Supervisor
from controller.runtime.tracking_metrics import PlanTrackingMetrics, TrackingMetrics, command_response_s
from controller.tracking.tracker import Tracker
from hw.robot import RobotInterface
from hw.types import RobotState

if TYPE_CHECKING:
    from controller.recording.recorder import FlightRecorder

log = logging.getLogger(__name__)


class Session:
    def __init__(
        self, backend: Backend, tracker: Tracker, source: CommandSource, reference: ReferenceSource | None = None,
        estimated: EstimatedRobot | None = None, record: Path | None = None,
    ) -> None:  # fmt: skip
        """`estimated`: the backend's robot read through a state estimator, what the controller sees instead; its fault
        holds position-based references, and where a simulator stands behind the robot the estimate is judged by its truth.
        `record`: an MCAP file that every tick is recorded into (`--record`); `close` finishes it."""
        self.backend = backend
        self.robot: EstimatedRobot | RobotInterface = estimated if estimated is not None else backend.robot
        self.tracker = tracker
        self.source = source
        self.reference = reference or CommandReference()
        self.supervisor = Supervisor()
        self.metrics = TrackingMetrics()  # judged by the truth where there is one, else by what the controller sees
        self.plan_metrics = PlanTrackingMetrics()
        self.estimated = estimated
        self.estimate_metrics = TrackingMetrics() if estimated is not None else None  # the same, as the estimate sees it
        self.estimate_judge = EstimateJudge() if estimated is not None else None
        self.step_times: list[float] = []  # seconds per tracker step (observation + inference + command)
        self.falls: list[float] = []  # run time of each fall
        self.damp_time: float | None = None  # run time at which the robot was last put into damping
        self.hold_time: float | None = None  # run time at which a failed estimate made the robot stand
        self.start_time = backend.now()
        self.ticks = 0
        self.last_window: ReferenceWindow | None = None  # for displays: the plan being tracked, the command
        self.recorder: FlightRecorder | None = None
        if record is not None:
            from controller.recording.recorder import FlightRecorder  # noqa: PLC0415 - mcap and protobuf only when recording

            run = {"tracker": tracker.name, "rate_hz": tracker.rate_hz, "backend": type(backend).__name__}
            self.recorder = FlightRecorder(record, backend.robot, estimated.estimator if estimated is not None else None, run)

    def start(self) -> None:
        """Bring the backend up; run time counts from here (hardware: after the soft start)."""
        self.backend.start()
        self.start_time = self.backend.now()
        self.reference.start(self.robot.read())

    def tick(self) -> bool:
        """One control period; False when the run cannot go on (a fall that software cannot undo)."""
        backend, tracker, supervisor = self.backend, self.tracker, self.supervisor
        state = self.robot.read()
        sample = self.source.poll(state.time)
        was_damping = supervisor.mode is Mode.DAMP
        fault = tracker.latched_fault or backend.fault()
        velocity = supervisor.update(sample, fault)
        if supervisor.mode is Mode.DAMP and not was_damping:
            self.damp_time = round(state.time - self.start_time, 4)
        truth = backend.truth()
        if truth is None and self.estimated is not None and backend.measures_base_position:
            truth = self.estimated.measured  # the simulator read directly is its own truth; the controller sees the estimate
        measured = truth or state  # metrics use the simulator's ground truth where there is one
        measured_velocity = self.metrics.record(measured.time, measured.base_pos, measured.base_quat, velocity)
        if self.estimated is not None:
            self._watch_estimate(state, truth, velocity)
        running = supervisor.mode is Mode.RUN
        window = self.reference.window(state, velocity, sample.gesture if running else "", hold=not running)
        self.last_window = window
        if window.plan is not None and supervisor.mode is not Mode.DAMP:
            self.plan_metrics.record(state.time, measured, window.plan)
        t0 = time.perf_counter()
        command = tracker.damping_command() if supervisor.mode is Mode.DAMP else tracker.step(state, window)
        self.step_times.append(time.perf_counter() - t0)
        self.robot.write(command)
        self.ticks += 1
        fell = backend.has_fallen()
        if self.recorder is not None:
            reading = self.estimated.measured if self.estimated is not None and self.estimated.measured is not None else state
            reason = supervisor.damp_reason if supervisor.mode is Mode.DAMP else supervisor.hold_reason
            self.recorder.record(
                Tick(
                    state, reading, truth, sample, velocity, measured_velocity, supervisor.mode.value, reason, fault, window, command, fell
                )
            )
        if fell:
            self.falls.append(round(state.time - self.start_time, 3))
            if supervisor.mode is Mode.DAMP or not backend.recover_from_fall():
                return False  # damped on purpose, or on hardware: nothing left to run
            tracker.reset()
            self.metrics.reset_reference()
            if self.estimated is not None and self.estimate_metrics is not None:
                self.estimated.reset()
                self.estimate_metrics.reset_reference()
                if self.estimate_judge is not None:
                    self.estimate_judge.restart()
            self.reference.start(self.robot.read())
        return True

    def _watch_estimate(self, estimate: RobotState, truth: RobotState | None, velocity: VelocityCommand) -> None:
        """The estimate's own view of the tracking, its judgement by the truth, and a hold once it fails."""
        assert self.estimated is not None and self.estimate_metrics is not None and self.estimate_judge is not None
        estimator = self.estimated.estimator
        self.estimate_metrics.record(estimate.time, estimate.base_pos, estimate.base_quat, velocity)
        if truth is not None:
            self.estimate_judge.record(estimate, truth, estimator.contacts, self.backend.truth_contacts())
        fault = estimator.fault
        if fault is not None and self.reference.needs_base_position and not self.supervisor.hold_reason:
            reason = f"state estimate lost ({fault}): standing, nothing walks to a position any more"
            log.error("%s", reason)
            self.supervisor.hold(reason)
            self.hold_time = round(estimate.time - self.start_time, 4)

    def fail(self, reason: str) -> None:
        """A fault outside the tick (bring-up): damp, latched, with the reason in the report."""
        if self.supervisor.mode is not Mode.DAMP:
            self.damp_time = round(self.backend.now() - self.start_time, 4)
        self.supervisor.damp(f"fault: {reason}")
        if self.recorder is not None:
            self.recorder.note("session", f"fault: {reason}")

    def close(self) -> None:
        """Finish the recording, if any (every exit path of a run; safe twice)."""
        if self.recorder is not None:
            self.recorder.close(self.backend.now())

    def recorder_report(self) -> dict[str, Any]:
        """The report's `recorder` block once `close`d: the file, its messages and bytes, the ticks dropped; {} when not recording."""
        return {"recorder": self.recorder.report()} if self.recorder is not None else {}

    def report(self) -> dict[str, Any]:
        """What happened so far: tracking figures, the final mode and why (the backend's counters: `Backend.report`)."""
        supervisor = self.supervisor
        report: dict[str, Any] = {
            "tracker": self.tracker.name,
            "run_seconds": round(self.backend.now() - self.start_time, 4),
            "falls": len(self.falls),
            "fall_times": self.falls,
            "velocity_error_mean": round(self.metrics.velocity_error_mean, 4),
            "yaw_rate_error_mean": round(self.metrics.yaw_rate_error_mean, 4),
            "policy_step_ms": percentiles_ms(self.step_times),
            "command_response_s": _rounded(command_response_s(self.metrics.times, self.metrics.commanded, self.metrics.measured)[0]),
            "nonfinite_actions": self.tracker.nonfinite_events,
            "final_mode": supervisor.mode.value,
            "damp_reason": supervisor.damp_reason,
            "damp_time": self.damp_time,
            "hold_reason": supervisor.hold_reason or None,
            "hold_time": self.hold_time,
            "estops": supervisor.estops,
            "input_losses": supervisor.input_losses,
        }
        if self.plan_metrics.times:
            report |= self.plan_metrics.report()
        report |= self.reference.report()
        if self.estimated is not None:
            report |= self._estimate_report(report)
        return report

    def _estimate_report(self, report: dict[str, Any]) -> dict[str, Any]:
        """The `estimator` block; the estimate's view of the tracking beside the truth's (or, with no truth, as the figures)."""
        assert self.estimated is not None and self.estimate_metrics is not None and self.estimate_judge is not None
        block = self.estimated.report() | self.estimate_judge.report()
        view = {
            "velocity_error_mean": round(self.estimate_metrics.velocity_error_mean, 4),
            "yaw_rate_error_mean": round(self.estimate_metrics.yaw_rate_error_mean, 4),
        }
        if not self.estimate_judge.report():  # no truth: the estimate is all there is
            return {"estimator": block, "measured_by": "estimate"}
        judged: dict[str, Any] = {}
        follower = self.reference.follower
        if follower is not None and "waypoint_errors" in report:
            view["waypoint_errors"] = report["waypoint_errors"]  # the follower's own, from the estimate
            judged["waypoint_errors"] = self.estimate_judge.waypoint_errors(follower.errors)
        block["controller_view"] = view
        return {"estimator": block, "measured_by": "truth"} | judged

    @property
    def ended_in_fault(self) -> bool:
        return self.supervisor.mode is Mode.DAMP and self.supervisor.damp_reason.startswith("fault")


def _rounded(value: float) -> float | None:
    return None if value != value else round(value, 3)  # NaN (nothing to measure) reads as null in JSON
