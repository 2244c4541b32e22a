"""The live status line: one line, rewritten in place, saying mode, command, measured velocity and plan latency."""

from __future__ import annotations

import io
from collections.abc import Callable
from pathlib import Path

import numpy as np

from controller.inputs.scripted import ScenarioStep, ScriptedSource
from controller.runtime.session import Session
from controller.runtime.sim_backends import DirectSimBackend
from controller.runtime.status import StatusLine, format_status
from controller.tracking.presets import load_policy
from hw.shipped import config_dir
from sim.robot import SimRobot


def test_status_line_shows_mode_command_and_measured_velocity(g1_model, assets, tmp_path: Path, linear_onnx: Callable[..., Path]) -> None:  # type: ignore[no-untyped-def]
    onnx = linear_onnx(np.zeros((100, 29)))
    preset = tmp_path / "tiny.yaml"
    preset.write_text((config_dir("policies") / "fastsac.yaml").read_text().replace("fastsac_g1_29dof.onnx", str(onnx)))
    robot = SimRobot(g1_model)
    tracker = load_policy(str(preset), assets, robot.joint_names)
    stream = io.StringIO()
    status = StatusLine(stream, refresh_s=0.0)
    with DirectSimBackend(robot) as backend, ScriptedSource((ScenarioStep(t=0.0, vx=0.3),)) as source:
        session = Session(backend, tracker, source)
        session.start()
        for k in range(5):
            backend.advance_to(session.start_time + k / 50)
            session.tick()
            status.update(session)
    status.close()
    text = stream.getvalue()
    assert text.count("\r") == 5 and text.endswith("\n")
    line = format_status(session)
    assert " | run | cmd vx +0.30 vy +0.00 wz +0.00 | meas vx " in line and "plan" not in line


def test_a_new_caption_is_shown_at_once(g1_model, assets, tmp_path: Path, linear_onnx: Callable[..., Path]) -> None:  # type: ignore[no-untyped-def]
    """A key typed into the text line shows at once, not at the next refresh; an unchanged caption waits for it."""
    onnx = linear_onnx(np.zeros((100, 29)))
    preset = tmp_path / "tiny.yaml"
    preset.write_text((config_dir("policies") / "fastsac.yaml").read_text().replace("fastsac_g1_29dof.onnx", str(onnx)))
    robot = SimRobot(g1_model)
    stream = io.StringIO()
    status = StatusLine(stream, refresh_s=60.0)
    with DirectSimBackend(robot) as backend, ScriptedSource((ScenarioStep(t=0.0),)) as source:
        session = Session(backend, load_policy(str(preset), assets, robot.joint_names), source)
        session.start()
        for caption in ("", "instruction> w_", "instruction> w_", "instruction> wa_"):
            status.update(session, caption)
    assert stream.getvalue().count("\r") == 3 and stream.getvalue().rstrip().endswith("instruction> wa_")
