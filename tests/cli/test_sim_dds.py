"""`g1ctl sim --hardware sim-dds`: the whole stack against the simulated G1 in its own process, over loopback DDS."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

import pytest

pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")

from tests.conftest import g1ctl

pytestmark = pytest.mark.slow


def test_walking_against_the_robot_in_its_own_process(tmp_path: Path, sim_dds_config: Callable[[], Path]) -> None:
    report_path = tmp_path / "report.json"
    hardware = sim_dds_config()
    result = g1ctl("sim", "--scenario", "walk_turn_stop", "--duration", "6", "--hardware", str(hardware), "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["falls"] == 0 and report["final_mode"] == "run"
    # It walked forward, seen through the robot's ground truth: 1.1 m here alone, 0.45 m with four such runs at once on two
    # cores (on the wall clock a loaded machine makes the robot's physics lag behind the host: the figure to judge is the
    # full scenario's velocity error in the README, not this short run's).
    assert report["final_base_position"][0] > 0.2 and report["velocity_error_mean"] < 0.3, report
    hw, robot = report["hw"], report["hw"]["robot_process"]
    assert robot["pid"] != os.getpid() and robot["exit_code"] == 0  # the physics ran in another process, stopped cleanly
    assert hw["released_mode"] == "ai" and robot["motion_mode"] == "" and robot["motion_release_requests"] == 1
    # 500 Hz for 6 s is 3000 cycles; a loaded machine takes fewer (2200 states and 2400 commands with four runs at once): half
    assert hw["cycles"] > 1500 and hw["states_received"] > 1500 and hw["crc_errors"] == 0 and hw["faults"] == 0
    assert robot["commands"] > 1500 and robot["crc_errors"] == 0 and robot["mode_machine_mismatches"] == 0
    assert robot["damping_commands"] >= 1  # the host damped the robot on its way out (keep-last-1: it may see one of three)
    assert hw["wire"]["outside_limits"] == 0 and hw["wire"]["commands"] == 29 * robot["commands"]  # the robot audited each one


def test_a_drill_on_the_robot_in_its_own_process_is_judged_on_what_it_took(tmp_path: Path, sim_dds_config: Callable[[], Path]) -> None:
    report_path = tmp_path / "report.json"
    hardware = str(sim_dds_config())
    result = g1ctl("sim", "--duration", "3.5", "--hardware", hardware, "--faults", "dds-stale", "--report", str(report_path))
    assert result.returncode == 0, result.stdout + result.stderr
    assert "drill dds-stale: passed (every motor safe" in result.stdout
    drill = json.loads(report_path.read_text())["drill"]
    # On the robot's clock: its physics catches up with the wall clock in steps on a loaded machine, so the host's 50 ms
    # watchdog can read a little less there (46 ms with two test runs at once).
    assert drill["fault_at_s"] == 3.0 and 0.0 < drill["damping_latency_s"] <= 0.1 and drill["outside_limits"] == 0
    assert any(f.startswith("robot state stale") for f in drill["faults"])
    refused = g1ctl("sim", "--hardware", hardware, "--faults", "overheat-left-knee")
    assert refused.returncode == 2 and "a DDS config has no buses to fault" in refused.stderr
