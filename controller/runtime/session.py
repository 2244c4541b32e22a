"""The session: one control tick shared by every backend, and the run's report.

A tick reads the robot, polls the command input, lets the supervisor decide the mode,
asks the tracker for a joint command on the reference window (or damps) and writes it.
The session imports no simulator: the same tick drives MuJoCo, simulated hardware and
real hardware through a `Backend`.
"""

from __future__ import annotations

import time
from typing import Any

from controller.inputs.base import CommandSource
from controller.reference.source import CommandReference, ReferenceSource
from controller.reference.window import ReferenceWindow
from controller.reports import percentiles_ms
from controller.runtime.backend import Backend
from controller.runtime.supervisor import Mode, Supervisor
from controller.runtime.tracking_metrics import PlanTrackingMetrics, TrackingMetrics, command_response_s
from controller.tracking.tracker import Tracker


class Session:
    def __init__(self, backend: Backend, tracker: Tracker, source: CommandSource, reference: ReferenceSource | None = None) -> None:
        self.backend = backend
        self.tracker = tracker
        self.source = source
        self.reference = reference or CommandReference()
        self.supervisor = Supervisor()
        self.metrics = TrackingMetrics()
        self.plan_metrics = PlanTrackingMetrics()
        self.step_times: list[float] = []  # seconds per tracker step (observation + inference + command)
        self.falls: list[float] = []  # run time of each fall
        self.damp_time: float | None = None  # run time at which the robot was last put into damping
        self.start_time = backend.now()
        self.ticks = 0
        self.last_window: ReferenceWindow | None = None  # for displays: the plan being tracked, the command

    def start(self) -> None:
        """Bring the backend up; run time counts from here (hardware: after the soft start)."""
        self.backend.start()
        self.start_time = self.backend.now()
        self.reference.start(self.backend.robot.read())

    def tick(self) -> bool:
        """One control period; False when the run cannot go on (a fall that software cannot undo)."""
        backend, tracker, supervisor = self.backend, self.tracker, self.supervisor
        state = backend.robot.read()
        sample = self.source.poll(state.time)
        was_damping = supervisor.mode is Mode.DAMP
        velocity = supervisor.update(sample, tracker.latched_fault or backend.fault())
        if supervisor.mode is Mode.DAMP and not was_damping:
            self.damp_time = round(state.time - self.start_time, 4)
        measured = backend.truth() or state  # metrics use the simulator's ground truth where there is one
        self.metrics.record(measured.time, measured.base_pos, measured.base_quat, velocity)
        running = supervisor.mode is Mode.RUN
        window = self.reference.window(state, velocity, sample.gesture if running else "", hold=not running)
        self.last_window = window
        if window.plan is not None and supervisor.mode is not Mode.DAMP:
            self.plan_metrics.record(state.time, measured, window.plan)
        t0 = time.perf_counter()
        command = tracker.damping_command() if supervisor.mode is Mode.DAMP else tracker.step(state, window)
        self.step_times.append(time.perf_counter() - t0)
        backend.robot.write(command)
        self.ticks += 1
        if backend.has_fallen():
            self.falls.append(round(state.time - self.start_time, 3))
            if supervisor.mode is Mode.DAMP or not backend.recover_from_fall():
                return False  # damped on purpose, or on hardware: nothing left to run
            tracker.reset()
            self.metrics.reset_reference()
            self.reference.start(backend.robot.read())
        return True

    def fail(self, reason: str) -> None:
        """A fault outside the tick (bring-up): damp, latched, with the reason in the report."""
        if self.supervisor.mode is not Mode.DAMP:
            self.damp_time = round(self.backend.now() - self.start_time, 4)
        self.supervisor.damp(f"fault: {reason}")

    def report(self) -> dict[str, Any]:
        """What happened so far: tracking figures, the final mode and why (the backend's counters: `Backend.report`)."""
        supervisor = self.supervisor
        report: dict[str, Any] = {
            "tracker": self.tracker.name,
            "sim_seconds": round(self.backend.now() - self.start_time, 4),
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
            "estops": supervisor.estops,
            "input_losses": supervisor.input_losses,
        }
        if self.plan_metrics.times:
            report |= self.plan_metrics.report()
        return report | self.reference.report()

    @property
    def ended_in_fault(self) -> bool:
        return self.supervisor.mode is Mode.DAMP and self.supervisor.damp_reason.startswith("fault")


def _rounded(value: float) -> float | None:
    return None if value != value else round(value, 3)  # NaN (nothing to measure) reads as null in JSON
