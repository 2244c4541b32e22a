"""Bring-up commands and `sim --hardware` through the real CLI against simulated hardware."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hw.shipped import config_dir
from tests.conftest import g1ctl, one_line_error


def test_frame_encode_decode_mit() -> None:
    result = g1ctl(
        "hw",
        "frame",
        "encode",
        "--protocol",
        "mit",
        "--model",
        "AK80-9",
        "--position",
        "1.0",
        "--velocity",
        "2.0",
        "--kp",
        "50",
        "--kd",
        "1",
        "--torque",
        "3",
    )
    assert result.returncode == 0 and result.stdout.strip() == "8a3c851199333954"
    decoded = json.loads(g1ctl("hw", "frame", "decode", "--protocol", "mit", "--model", "AK80-9", "8a3c851199333954").stdout)
    assert decoded["kind"] == "command" and decoded["kp"] == pytest.approx(50, abs=0.2)
    reply = json.loads(
        g1ctl("hw", "frame", "decode", "--protocol", "mit", "--model", "AK80-9", "--reply", "cubemars", "057fff7ff7fffb01").stdout
    )
    assert reply["motor_id"] == 5 and reply["error"] == "motor over-temperature" and reply["temperature"] == -5
    special = json.loads(g1ctl("hw", "frame", "decode", "--protocol", "mit", "fffffffffffffffc").stdout)
    assert special == {"kind": "special", "special": "enter"}


def test_frame_encode_decode_rs485() -> None:
    result = g1ctl(
        "hw",
        "frame",
        "encode",
        "--protocol",
        "unitree-rs485",
        "--id",
        "1",
        "--mode",
        "1",
        "--torque",
        "0.5",
        "--velocity",
        "1.0",
        "--position",
        "0.1",
        "--kp",
        "0.2",
        "--kd",
        "0.05",
    )
    frame = result.stdout.strip()
    assert frame.startswith("feee1180002800090200000001400046") and len(frame) == 34
    decoded = json.loads(g1ctl("hw", "frame", "decode", "--protocol", "unitree-rs485", frame).stdout)
    assert decoded["kind"] == "command" and decoded["motor_id"] == 1 and decoded["torque"] == 0.5


def test_frame_encode_decode_unitree_hg() -> None:
    args = ("--id", "3", "--mode", "1", "--position", "0.25", "--velocity", "-1", "--torque", "0.5", "--kp", "60", "--kd", "1.5")
    result = g1ctl("hw", "frame", "encode", "--protocol", "unitree-hg", *args, "--mode-machine", "5")
    frame = result.stdout.strip()
    assert result.returncode == 0 and len(frame) == 2 * 1004 and frame.startswith("0005") and frame.endswith("62a619fc")
    decoded = json.loads(g1ctl("hw", "frame", "decode", "--protocol", "unitree-hg", frame).stdout)
    assert decoded["kind"] == "LowCmd_" and decoded["mode_machine"] == 5 and decoded["motors"]["3"]["kp"] == 60.0
    assert "LowCmd_ CRC mismatch" in one_line_error(g1ctl("hw", "frame", "decode", "--protocol", "unitree-hg", frame[:-8] + "00000000"))
    assert "LowCmd_ (1004 bytes) or LowState_ (2092)" in one_line_error(g1ctl("hw", "frame", "decode", "--protocol", "unitree-hg", "00ff"))


def test_frame_bad_input_is_one_line() -> None:
    assert "CRC mismatch" in one_line_error(
        g1ctl("hw", "frame", "decode", "--protocol", "unitree-rs485", "feee118000280009020000000140004691")
    )
    assert "not hex" in one_line_error(g1ctl("hw", "frame", "decode", "--protocol", "mit", "--model", "AK80-9", "zz"))
    assert "unknown motor model 'AK99'" in one_line_error(g1ctl("hw", "frame", "encode", "--protocol", "mit", "--model", "AK99"))
    assert "must be 8 bytes" in one_line_error(g1ctl("hw", "frame", "decode", "--protocol", "mit", "--model", "AK80-9", "7fff"))
    assert "motor id must be 0-15" in one_line_error(g1ctl("hw", "frame", "encode", "--protocol", "unitree-rs485", "--id", "16"))


@pytest.mark.slow
def test_scan_finds_every_motor_on_simulated_buses() -> None:
    result = g1ctl("hw", "scan", "--hardware", "sim-mixed")
    assert result.returncode == 0, result.stderr
    assert "29/29 motors answered" in result.stdout
    assert "rs485_left" in result.stdout and "can1" in result.stdout


@pytest.mark.slow
def test_sweep_imu_damp_zero_on_simulated_hardware() -> None:
    sweep = g1ctl("hw", "sweep", "--hardware", "sim-can", "--joint", "left_elbow_joint", "--fraction", "0.1", "--speed", "1.0", "--yes")
    assert sweep.returncode == 0, sweep.stderr
    result = json.loads(sweep.stdout)
    assert result["completed"] and result["low"] < result["high"]
    imu = json.loads(g1ctl("hw", "imu", "--hardware", "sim-can", "--seconds", "0.2").stdout)
    assert imu["frames"] >= 90 and imu["samples"] >= 90 and imu["crc_errors"] == 0
    assert imu["accel_mean"][2] == pytest.approx(9.81, abs=0.15)  # the robot hangs still: its mean is gravity
    assert g1ctl("hw", "damp", "--hardware", "sim-can", "--seconds", "0.1").returncode == 0
    zero = json.loads(g1ctl("hw", "zero", "--hardware", "sim-mixed", "--joint", "left_knee_joint", "--yes").stdout)
    assert zero["zero_offset"] == pytest.approx(-0.669, abs=0.01)


@pytest.mark.slow
def test_bringup_bad_input_is_one_line() -> None:
    line = one_line_error(g1ctl("hw", "scan", "--hardware", "moon-robot"))
    assert "unknown hardware config 'moon-robot'" in line and "sim-can" in line
    line = one_line_error(g1ctl("hw", "sweep", "--hardware", "sim-can", "--joint", "left_knee", "--yes"))
    assert "unknown joint 'left_knee'" in line
    line = one_line_error(g1ctl("hw", "zero", "--hardware", "sim-can", "--joint", "left_knee_joint"))
    assert "pass --yes" in line
    line = one_line_error(g1ctl("hw", "damp", "--hardware", "sim-can", "--rt-priority", "120"))
    assert "real-time priority 120 is out of range" in line


def test_joint_map_with_duplicate_id_is_named(tmp_path: Path) -> None:
    text = config_dir("hardware", "sim-can.yaml").read_text()
    bad = tmp_path / "dup.yaml"
    bad.write_text(
        text.replace(
            "left_hip_roll_joint: {bus: can0, protocol: mit, model: sim-leg-150, reply: cubemars, id: 2",
            "left_hip_roll_joint: {bus: can0, protocol: mit, model: sim-leg-150, reply: cubemars, id: 1",
        )
    )
    line = one_line_error(g1ctl("hw", "scan", "--hardware", str(bad)))
    assert "left_hip_pitch_joint and left_hip_roll_joint share motor id 1 on bus 'can0'" in line
    missing = tmp_path / "missing.yaml"
    missing.write_text("\n".join(ln for ln in text.splitlines() if not ln.strip().startswith("right_wrist_yaw_joint")))
    assert "joints missing from the joint map: right_wrist_yaw_joint" in one_line_error(g1ctl("hw", "scan", "--hardware", str(missing)))


def test_a_joint_limit_wider_than_the_g1s_is_refused_in_one_line(tmp_path: Path) -> None:
    knee = "left_knee_joint: {bus: can0, protocol: mit, model: sim-leg-150, reply: cubemars, id: 4"
    text = config_dir("hardware", "sim-can.yaml").read_text()
    assert knee in text
    bad = tmp_path / "wide-knee.yaml"
    bad.write_text(text.replace(knee, knee + ", position_limits: [-0.2, 3.0]"))
    line = one_line_error(g1ctl("hw", "scan", "--hardware", str(bad)))
    assert line.endswith(
        f"{bad}: joints.left_knee_joint.position_limits [-0.2, 3.0] is wider than the G1's [-0.087267, 2.8798] "
        "(hw/g1.py, from the MJCF): narrow it or remove it"
    ), line
    dds = tmp_path / "fast-dds.yaml"
    text = config_dir("hardware", "sim-dds.yaml").read_text()
    dds.write_text(text.replace("mode_pr: 0", "mode_pr: 0\njoints: {waist_yaw_joint: {velocity_limit: 40}}"))
    line = one_line_error(g1ctl("hw", "scan", "--hardware", str(dds)))
    assert f"{dds}: joints.waist_yaw_joint.velocity_limit 40.0 is wider than the G1's 30.0" in line, line


@pytest.mark.slow
def test_walking_through_simulated_can_hardware(tmp_path: Path) -> None:
    report_path = tmp_path / "hw.json"
    result = g1ctl("sim", "--hardware", "sim-can", "--duration", "3", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["falls"] == 0 and report["final_base_position"][0] > 0.5
    hw = report["hw"]
    assert hw["faults"] == 0 and hw["frames_received"] > 29 * 1400
    assert set(hw["cycle_ms"]) == {"p50", "p99"} and hw["crc_errors"] == 0


@pytest.mark.slow
def test_fault_files_inject_into_simulated_hardware(tmp_path: Path) -> None:
    report_path = tmp_path / "lossy.json"
    lossy = str(config_dir("faults") / "lossy-can.yaml")
    result = g1ctl("sim", "--hardware", "sim-can", "--faults", lossy, "--duration", "1.5", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    hw = json.loads(report_path.read_text())["hw"]
    assert hw["faults"] == 0 and hw["dropped"] > 0 and hw["error_frames"] > 0  # counted, ridden through

    overheat_path = tmp_path / "overheat.json"
    overheat = g1ctl("sim", "--hardware", "sim-can", "--faults", "overheat-left-knee", "--duration", "3.5", "--report", str(overheat_path))
    assert overheat.returncode == 0, overheat.stderr  # a drill's exit status is its verdict
    assert "left_knee_joint" in overheat.stderr and "over-temperature" in overheat.stderr
    assert "drill overheat-left-knee: passed (every motor safe" in overheat.stdout
    report = json.loads(overheat_path.read_text())
    assert report["final_mode"] == "damp" and "over-temperature" in report["damp_reason"] and report["damp_time"] is not None
    assert report["hw"]["faults"] >= 1 and report["hw"]["state"] in ("error", "closed") and report["hw"]["frames_sent"] > 0
    drill = report["drill"]
    assert drill["passed"] and drill["fault_at_s"] == 3.0 and 0 <= drill["damping_latency_s"] <= 0.02
    assert drill["limp_joints"] == ["left_knee_joint"] and report["hw"]["wire"]["outside_limits"] == 0
    assert overheat_path.with_suffix(".png").is_file()

    early = g1ctl("sim", "--hardware", "sim-can", "--faults", "overheat-left-knee", "--duration", "1")
    assert early.returncode == 1 and "before the fault struck at 3.00 s: run it longer" in early.stdout

    at_bring_up = tmp_path / "hot-at-start.yaml"  # a fault from the start: bring-up refuses to activate, and still reports
    at_bring_up.write_text("buses:\n  can0: {over_temperature: [4]}\n")
    refused = g1ctl("sim", "--hardware", "sim-can", "--faults", str(at_bring_up), "--duration", "1", "--report", str(tmp_path / "r.json"))
    assert refused.returncode == 0 and "cannot activate: left_knee_joint" in refused.stderr
    assert json.loads((tmp_path / "r.json").read_text())["drill"]["damping_latency_s"] == 0.0
    silent = g1ctl("sim", "--hardware", "sim-can", "--faults", "can0-silent-at-bring-up", "--duration", "1")
    assert silent.returncode == 0 and "drill can0-silent-at-bring-up: passed" in silent.stdout  # configure names the silent motors
    assert "motors did not answer: left_hip_pitch_joint (bus can0, id 1)" in silent.stderr

    assert "--faults needs --hardware" in one_line_error(g1ctl("sim", "--faults", lossy))
    bad = tmp_path / "bad.yaml"
    bad.write_text("buses:\n  can9: {drop_reply_prob: 0.1}\n")
    assert "buses ['can9'] are not in the hardware config" in one_line_error(g1ctl("sim", "--hardware", "sim-can", "--faults", str(bad)))
