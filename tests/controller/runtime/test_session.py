"""The session's tick on the real G1 model and a tiny ONNX policy; the run's report on every exit path."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from controller.commands.waypoints import WorldWaypoint
from controller.estimation.estimator import StateEstimator
from controller.inputs.scripted import ScenarioStep, ScriptedSource
from controller.reference.waypoints import WaypointFollower, WaypointReference
from controller.runtime.driver import run
from controller.runtime.estimation import EstimatedRobot
from controller.runtime.run_config import RunConfig
from controller.runtime.session import Session
from controller.runtime.sim_backends import DirectSimBackend
from controller.tracking.presets import load_policy
from controller.tracking.registry import TrackerSpec, available_trackers, make_tracker
from hw.errors import ConfigError, RunAborted
from hw.shipped import config_dir
from hw.types import RobotState
from sim.robot import SimRobot


def tiny_policy_yaml(tmp_path: Path, linear_onnx: Callable[..., Path], nan_output: bool = False) -> Path:
    """The fastsac preset with its ONNX file swapped for a zero (or NaN) linear graph of the same shape."""
    onnx = linear_onnx(np.zeros((100, 29)), name="tiny.onnx", nan_output=nan_output)
    text = (config_dir("policies") / "fastsac.yaml").read_text().replace("fastsac_g1_29dof.onnx", str(onnx))
    path = tmp_path / "tiny.yaml"
    path.write_text(text)
    return path


def standing() -> ScriptedSource:
    return ScriptedSource((ScenarioStep(t=0.0, label="stand"),))


def test_ticks_track_and_count(g1_model, assets, tmp_path: Path, linear_onnx) -> None:  # type: ignore[no-untyped-def]
    robot = SimRobot(g1_model)
    tracker = load_policy(str(tiny_policy_yaml(tmp_path, linear_onnx)), assets, robot.joint_names)
    backend = DirectSimBackend(robot)
    with backend, standing() as source:
        session = Session(backend, tracker, source)
        session.start()
        for k in range(25):
            backend.advance_to(session.start_time + k / tracker.rate_hz)
            assert session.tick()
        report = session.report()
    assert report["tracker"] == "velocity" and report["final_mode"] == "run" and report["damp_time"] is None
    assert report["run_seconds"] == pytest.approx(24 / 50, abs=1e-6)
    assert len(session.step_times) == 25 and set(report["policy_step_ms"]) == {"p50", "p99"}
    assert "hw" not in report


def test_nonfinite_tracker_damps_and_the_session_says_when(g1_model, assets, tmp_path: Path, linear_onnx) -> None:  # type: ignore[no-untyped-def]
    robot = SimRobot(g1_model)
    tracker = load_policy(str(tiny_policy_yaml(tmp_path, linear_onnx, nan_output=True)), assets, robot.joint_names)
    backend = DirectSimBackend(robot)
    with backend, standing() as source:
        session = Session(backend, tracker, source)
        session.start()
        for k in range(6):
            backend.advance_to(session.start_time + k / tracker.rate_hz)
            session.tick()
        report = session.report()
    assert session.ended_in_fault and report["final_mode"] == "damp"
    assert "non-finite" in report["damp_reason"] and report["damp_time"] == pytest.approx(3 / 50)
    assert report["nonfinite_actions"] == 3


def test_unknown_tracker_lists_the_valid_ones(assets) -> None:  # type: ignore[no-untyped-def]
    assert "velocity" in available_trackers()
    with pytest.raises(ConfigError, match=r"unknown tracker 'mimic' \(valid: .*velocity"):
        make_tracker("mimic", TrackerSpec("fastsac", assets, ()))


def test_an_error_mid_run_still_writes_the_report_and_plot(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A physics step that raises half a second in: the run stops, reports what it had, and fails loudly."""
    real_step_until = SimRobot.step_until

    def step_until(self: SimRobot, t: float) -> None:
        if t > 0.5:
            raise RuntimeError("injected: the simulator stopped")
        real_step_until(self, t)

    monkeypatch.setattr(SimRobot, "step_until", step_until)
    report_path = tmp_path / "r.json"
    with pytest.raises(RunAborted, match=r"run aborted after 0\.4[0-9]* s: injected: the simulator stopped; report: "):
        run(RunConfig(duration=2.0, report=report_path))
    report = json.loads(report_path.read_text())
    assert report["error"] == "RuntimeError: injected: the simulator stopped"
    assert report["run_seconds"] == pytest.approx(0.5, abs=0.03) and report["falls"] == 0
    assert report_path.with_suffix(".png").stat().st_size > 10_000


def test_an_estimator_fault_holds_a_position_reference_standing(g1_model, assets, tmp_path: Path, linear_onnx) -> None:  # type: ignore[no-untyped-def]
    """Waypoints walk to positions: once the estimate is lost the robot stands for good, and the report says why and when."""
    robot = SimRobot(g1_model)
    tracker = load_policy(str(tiny_policy_yaml(tmp_path, linear_onnx)), assets, robot.joint_names)
    estimated = EstimatedRobot(robot, StateEstimator.for_g1(robot.joint_names, assets_dir=str(assets.root)))
    reference = WaypointReference(WaypointFollower([WorldWaypoint(1.0, 0.0)], limits=tracker.command_limits))
    backend = DirectSimBackend(robot)
    read = robot.read
    broken = {"imu": False}

    def reading() -> RobotState:
        state = read()
        return dataclasses.replace(state, imu_accel=np.full(3, np.nan)) if broken["imu"] else state

    robot.read = reading  # type: ignore[method-assign]
    with backend, standing() as source:
        session = Session(backend, tracker, source, reference, estimated)
        session.start()
        for k in range(10):
            broken["imu"] = k >= 5
            backend.advance_to(session.start_time + k / tracker.rate_hz)
            assert session.tick()
        report = session.report()
    assert report["final_mode"] == "stand" and not report["damp_reason"]
    assert report["hold_reason"] == "state estimate lost (non-finite input: imu_accel): standing, nothing walks to a position any more"
    assert report["hold_time"] == pytest.approx(5 / 50) and report["estimator"]["fault"] == "non-finite input: imu_accel"
