"""`g1ctl hw scan|sweep|imu` on the simulated G1 over DDS (its own process, on a virtual gantry); `hw zero` refused."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

from controller.cli.main import main
from hw.g1 import JOINT_NAMES
from tests.conftest import g1ctl


def test_zero_is_refused_on_a_g1_over_dds_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["hw", "zero", "--hardware", "sim-dds"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "zero has no meaning on a G1 over DDS" in err[0] and "no encoder-zero command" in err[0]


@pytest.mark.slow  # starts the simulated robot process
def test_scan_lists_the_29_joints_healthy(sim_dds_config: Callable[[], Path]) -> None:
    pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")
    result = g1ctl("hw", "scan", "--hardware", str(sim_dds_config()))
    assert result.returncode == 0, result.stderr
    rows = [line.split() for line in result.stdout.splitlines() if line.split()[:1] and line.split()[0] in JOINT_NAMES]
    assert [r[0] for r in rows] == list(JOINT_NAMES) and all(r[4] == "0x00000000" for r in rows)
    assert "29/29 joints healthy" in result.stdout
    assert "mode_machine 5; high-level motion mode: 'ai' active" in result.stdout  # a scan only listens: the mode is left alone


@pytest.mark.slow
def test_sweep_completes_on_the_gantry(sim_dds_config: Callable[[], Path]) -> None:
    pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")
    args = ("--joint", "left_elbow_joint", "--fraction", "0.1", "--speed", "1.0", "--yes")
    result = g1ctl("hw", "sweep", *args, "--hardware", str(sim_dds_config()))
    assert result.returncode == 0, result.stderr
    sweep = json.loads(result.stdout)
    assert sweep["completed"] and sweep["low"] < sweep["high"] and sweep["max_abs_torque"] > 0


@pytest.mark.slow
def test_imu_reads_an_upright_robot(sim_dds_config: Callable[[], Path]) -> None:
    pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")
    result = g1ctl("hw", "imu", "--seconds", "0.3", "--hardware", str(sim_dds_config()))
    assert result.returncode == 0, result.stderr
    imu = json.loads(result.stdout)
    assert imu["quaternion_wxyz"] == pytest.approx([1.0, 0.0, 0.0, 0.0], abs=0.02)
    # 500 Hz for 0.3 s is 150 states; a loaded machine takes fewer (365 Hz with four reads at once): half
    assert imu["frames"] > 75 and imu["samples"] > 75 and imu["crc_errors"] == 0 and imu["rate_hz"] > 250
