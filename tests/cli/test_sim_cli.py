"""The real CLI in a subprocess: a short walk, and one clear line for each user mistake."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from tests.conftest import ROOT, g1ctl, one_line_error


@pytest.mark.slow
def test_five_seconds_of_walking(tmp_path: Path) -> None:
    report_path = tmp_path / "report.json"
    result = g1ctl("sim", "--scenario", "walk_turn_stop", "--duration", "5", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["run_seconds"] == pytest.approx(5.0)
    assert report["falls"] == 0
    assert report["final_base_position"][0] > 1.0  # 4 s at 0.5 m/s forward
    assert report["overruns"] == 0 and report["nonfinite_actions"] == 0
    for key in ("wall_seconds", "real_time_factor", "velocity_error_mean", "yaw_rate_error_mean"):
        assert isinstance(report[key], float)
    assert set(report["policy_step_ms"]) == {"p50", "p99"}
    assert Path(report["plot"]).is_file() and Path(report["plot"]).stat().st_size > 10_000


@pytest.mark.slow
def test_video_and_picture_are_written(tmp_path: Path) -> None:
    video, picture = tmp_path / "walk.gif", tmp_path / "last.png"
    result = g1ctl("sim", "--duration", "0.5", "--video", str(video), "--video-fps", "10", "--picture", str(picture))
    assert result.returncode == 0, result.stderr
    assert video.stat().st_size > 10_000
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_nan_policy_is_held_then_damped_and_counted(tmp_path: Path) -> None:
    import numpy as np

    from tests.conftest import make_linear_onnx

    make_linear_onnx(tmp_path / "nan.onnx", np.zeros((100, 29)), nan_output=True)
    text = (ROOT / "configs" / "policies" / "fastsac.yaml").read_text().replace("fastsac_g1_29dof.onnx", "nan.onnx")
    (tmp_path / "nan.yaml").write_text(text)
    report_path = tmp_path / "nan.json"
    result = g1ctl("sim", "--policy", str(tmp_path / "nan.yaml"), "--duration", "2", "--report", str(report_path))
    assert result.returncode == 1
    assert "non-finite" in result.stderr and "Traceback" not in result.stderr
    report = json.loads(report_path.read_text())
    assert report["nonfinite_actions"] == 3
    assert report["final_mode"] == "damp" and report["damp_reason"].startswith("fault")


def test_unknown_scenario_lists_valid_ones() -> None:
    line = one_line_error(g1ctl("sim", "--scenario", "moonwalk"))
    assert "unknown scenario 'moonwalk'" in line and "walk_turn_stop" in line and "random_commands" in line


@pytest.mark.slow
def test_unknown_policy_lists_valid_ones() -> None:
    line = one_line_error(g1ctl("sim", "--policy", "sac"))
    assert "unknown policy 'sac'" in line and "fastsac" in line and "ppo" in line


def test_scenario_file_with_unknown_key(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("duration: 5\nsteps:\n  - {t: 0.0, vz: 1.0}\n")
    line = one_line_error(g1ctl("sim", "--scenario", str(bad)))
    assert str(bad) in line and "unknown key 'steps[0].vz'" in line


@pytest.mark.slow
def test_policy_yaml_with_mismatched_layout(tmp_path: Path) -> None:
    text = (ROOT / "configs" / "policies" / "fastsac.yaml").read_text()
    bad = tmp_path / "short.yaml"
    bad.write_text(text.replace("    - {name: sin_phase, dim: 2, scale: 1.0}\n", ""))
    line = one_line_error(g1ctl("sim", "--policy", str(bad), "--duration", "1"))
    assert "fastsac_g1_29dof.onnx" in line and "takes 100 values but the observation layout makes 98" in line


def test_corrupt_asset_dir(tmp_path: Path, assets) -> None:
    local = tmp_path / "assets"
    shutil.copytree(assets.root, local)
    (local / "g1" / "g1_29dof.xml").write_text("<mujoco>")
    line = one_line_error(g1ctl("--assets-dir", str(local), "sim", "--duration", "1"))
    assert "checksum mismatch for g1/g1_29dof.xml" in line


@pytest.mark.slow
def test_gamepad_absent_is_one_line() -> None:
    line = one_line_error(g1ctl("sim", "--input", "gamepad", "--duration", "1"))
    assert "gamepad" in line


def test_nonpositive_duration() -> None:
    line = one_line_error(g1ctl("sim", "--duration", "0"))
    assert "--duration must be positive" in line


@pytest.mark.slow
def test_viewer_without_a_display_is_one_line() -> None:
    line = one_line_error(g1ctl("sim", "--viewer", "--duration", "0.1", env={"DISPLAY": "", "WAYLAND_DISPLAY": ""}))
    assert "needs a display" in line and "--video" in line


@pytest.mark.slow
def test_walking_through_the_planner_in_the_loop(tmp_path: Path) -> None:
    report_path = tmp_path / "planned.json"
    result = g1ctl("sim", "--scenario", "walk_turn_stop", "--planner", "--duration", "4", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["tracker"] == "decoupled" and report["falls"] == 0
    assert report["replans"] >= 35 and report["late_plans"] == 0 and report["planner_failures"] == 0
    assert set(report["plan_latency_ms"]) == {"p50", "p99"}
    assert report["plan_resyncs_per_plan"] == round(report["plan_resyncs"] / report["replans"], 4)
    spikes = report["plan_velocity_spikes"]
    assert report["plan_velocity_spike_share"] == round(spikes / 199, 6)  # of the 199 steps between 200 ticks
    assert report["plan_wild_frames"] == 0 and report["plan_unreachable_targets"] == 0  # walking at 0.5 m/s
    assert spikes == 0 and report["plan_joint_values_beyond_limits"] == 0  # limits in the planner's output space
    assert 0.0 < report["plan_foot_skate_mps"] < 0.5
    assert report["final_base_position"][0] > 0.5  # 3 s at up to 0.5 m/s forward, springing up to speed
    assert "unknown tracker 'wholebody'" in one_line_error(g1ctl("sim", "--planner", "--tracker", "wholebody"))


@pytest.mark.slow
def test_run_headless_without_a_terminal_plays_the_scenario_through_the_planner(tmp_path: Path) -> None:
    report_path = tmp_path / "run.json"
    result = g1ctl("run", "--duration", "2", "--report", str(report_path), env={"DISPLAY": "", "WAYLAND_DISPLAY": ""})
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["scenario"] == "walk_turn_stop" and report["tracker"] == "decoupled" and report["replans"] >= 15
