"""The bench scripts of examples/ run as a bench engineer runs them (`python examples/NAME.py --hardware ...`), each in a
process of its own, on simulated hardware: the buses in the script's own process (sim-can, sim-mixed), and the G1 in a
robot process the script starts (sim-dds). They are kept short: a small `--seconds`, a small share of each range.
Their failures too: silent motors fail the motor check, a bus that does not open is one line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from hw.g1 import JOINT_NAMES, LEFT_LEG_JOINTS
from hw.shipped import config_dir
from tests.conftest import ROOT, sim_can_on_real_buses

EXAMPLES = ROOT / "examples"

# The simulated robots the examples run on: simulated buses in the example's process, and the simulated G1 in a robot
# process of its own. The bus robot in its own process (issue 22 point 3, `sim-can-process`) joins the second kind here
# once a hardware config can name it.
ROBOTS = (
    pytest.param("sim-can", id="sim-can-in-process"),
    pytest.param("sim-mixed", id="sim-mixed-in-process"),
    pytest.param("sim-dds", id="sim-dds-robot-process"),
    pytest.param("sim-can-process", id="sim-can-robot-process"),
)
IMU_BIAS = {"accel_bias": (0.1, -0.05, 0.2), "gyro_bias": (0.01, -0.02, 0.005)}  # put into the simulated IMU, measured back


def run_example(name: str, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(EXAMPLES / f"{name}.py"), *args], capture_output=True, text=True, cwd=cwd, timeout=300)


def needs_the_robot_extra(hardware: str) -> None:
    if "dds" in hardware:
        pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")


def with_a_biased_imu(hardware: str, tmp_path: Path) -> Path:
    """A copy of the shipped simulated config whose IMU has the biases of `IMU_BIAS`."""
    text = (config_dir("hardware") / f"{hardware}.yaml").read_text()
    zero = "accel_bias: [0.0, 0.0, 0.0], gyro_bias: [0.0, 0.0, 0.0]"
    assert zero in text, hardware
    biased = ", ".join(f"{key}: [{', '.join(map(str, value))}]" for key, value in IMU_BIAS.items())
    path = tmp_path / f"{hardware}-biased-imu.yaml"
    path.write_text(text.replace(zero, biased))
    return path


def test_every_example_is_tested() -> None:
    assert sorted(p.stem for p in EXAMPLES.glob("*.py")) == ["check_motors", "imu_bias", "sweep_leg"]


@pytest.mark.slow
@pytest.mark.parametrize("hardware", ROBOTS)
def test_check_motors(hardware: str, tmp_path: Path) -> None:
    needs_the_robot_extra(hardware)
    result = run_example("check_motors", "--hardware", hardware, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert f"29/29 motors answered healthy; hottest {JOINT_NAMES[0]} at " in result.stdout
    listed = [line.split()[0] for line in result.stdout.splitlines() if line.split()[:1] and line.split()[0] in JOINT_NAMES]
    assert listed == list(JOINT_NAMES) and "FAIL" not in result.stdout


@pytest.mark.slow
@pytest.mark.parametrize("hardware", ROBOTS)
def test_sweep_leg(hardware: str, tmp_path: Path) -> None:
    needs_the_robot_extra(hardware)
    result = run_example("sweep_leg", "--hardware", hardware, "--leg", "left", "--fraction", "0.05", "--speed", "1", cwd=tmp_path)
    assert result.returncode == 0, (result.stdout, result.stderr)
    swept = [line.split()[1] for line in result.stdout.splitlines() if line.startswith("ok ")]
    assert swept == list(LEFT_LEG_JOINTS)
    assert "6/6 joints of the left leg reached their range (tolerance 0.05 rad)" in result.stdout


@pytest.mark.slow
@pytest.mark.parametrize("hardware", ROBOTS)
def test_imu_bias(hardware: str, tmp_path: Path) -> None:
    needs_the_robot_extra(hardware)
    log = tmp_path / "imu.csv"
    result = run_example(
        "imu_bias", "--hardware", str(with_a_biased_imu(hardware, tmp_path)), "--seconds", "0.5", "--csv", str(log), cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    printed = {line.split(":")[0]: [float(v) for v in line.split(":")[1].split()] for line in result.stdout.splitlines() if "bias" in line}
    assert printed["gyro bias  (rad/s)"] == pytest.approx(IMU_BIAS["gyro_bias"], abs=0.002)  # noise: 0.0039 rad/s a sample
    assert printed["accel bias (m/s^2)"] == pytest.approx(IMU_BIAS["accel_bias"], abs=0.02)
    rows = log.read_text().splitlines()
    assert rows[0] == "time,qw,qx,qy,qz,gx,gy,gz,ax,ay,az" and len(rows) > 100  # 250 at 500 Hz; fewer on a loaded machine


def test_check_motors_fails_when_motors_are_silent(tmp_path: Path) -> None:
    result = run_example("check_motors", "--hardware", str(sim_can_on_real_buses(tmp_path)), cwd=tmp_path)
    assert result.returncode == 1, result.stderr
    assert "0/29 motors answered healthy" in result.stdout and "FAIL left_hip_pitch_joint: no reply" in result.stdout


@pytest.mark.parametrize("example", ["check_motors", "sweep_leg", "imu_bias"])
def test_a_bus_that_cannot_be_opened_is_one_line(example: str, tmp_path: Path) -> None:
    config = sim_can_on_real_buses(tmp_path, can0="{kind: can, interface: socketcan, channel: g1-missing0, bitrate: 1000000}")
    result = run_example(example, "--hardware", str(config), cwd=tmp_path)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1, result.stderr
    assert lines[0].startswith(f"{example}: cannot open CAN bus 'can0' (socketcan:g1-missing0): ")
