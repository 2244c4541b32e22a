"""`g1ctl run --hardware` with a real robot's config: the stack drives whatever G1 answers on that domain, no simulator.

Here the G1 is `g1ctl robot --dds` started by hand, as a robot is powered on by hand; the config
is a copy of `g1-dds.yaml` pointed at loopback. The run must not import MuJoCo itself.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")

from tests.conftest import a_robot_config, g1ctl, one_line_error


@pytest.mark.slow
def test_run_drives_a_robot_that_answers_on_the_configs_domain(tmp_path: Path, claim_dds_domain: Callable[[], int]) -> None:
    domain = claim_dds_domain()
    robot = subprocess.Popen(
        [sys.executable, "-m", "controller.cli", "robot", "--dds", "--domain", str(domain), "--duration", "60"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        report_path = tmp_path / "run.json"
        args = ("--hardware", str(a_robot_config(tmp_path, domain)), "--input", "scripted", "--duration", "4", "--no-planner", "--headless")
        result = g1ctl("run", *args, "--report", str(report_path))
        assert result.returncode == 0, result.stderr
    finally:
        robot.send_signal(signal.SIGTERM)
        out, err = robot.communicate(timeout=20)
    report = json.loads(report_path.read_text())
    assert report["final_mode"] == "run" and report["falls"] == 0 and report["run_seconds"] == pytest.approx(4.0, abs=0.1)
    hw = report["hw"]
    # 500 Hz for 4 s is 2000 cycles; a loaded machine takes fewer (1344 commands beside another test run): half
    assert hw["released_mode"] == "ai" and hw["faults"] == 0 and hw["cycles"] > 1000 and hw["crc_errors"] == 0
    # no truth on a robot: the state estimator ran at the tracker's rate, and the figures are its
    assert report["measured_by"] == "estimate" and report["estimator"]["fault"] is None and "judged_by" not in report["estimator"]
    assert report["estimator"]["rate_hz"] > 40.0 and report["velocity_error_mean"] < 0.3  # 50 Hz, less on a loaded machine
    counters = json.loads(out.strip().splitlines()[-1])
    assert robot.returncode == 0, err
    assert counters["commands"] > 1000 and counters["motion_mode"] == "" and counters["damping_commands"] >= 1
    assert counters["sim_seconds"] > 3.5  # it walked: physics ran for the whole run


def test_sim_refuses_a_real_robot_in_one_line(tmp_path: Path, claim_dds_domain: Callable[[], int]) -> None:
    result = g1ctl("sim", "--duration", "1", "--hardware", str(a_robot_config(tmp_path, claim_dds_domain())))
    assert result.returncode == 2
    assert "is a real robot: g1ctl sim simulates; drive it with g1ctl run --hardware" in one_line_error(result)


def test_a_robot_run_imports_no_simulator() -> None:
    """`g1ctl run` and `g1ctl plan` on a real robot: the run, its state estimator, its recording and the text job load no MuJoCo."""
    code = (
        "import sys; import controller.runtime.driver, controller.runtime.dds_backend, controller.runtime.run_plan, "
        "controller.runtime.backend_registry, controller.cli.sim, controller.cli.run, controller.cli.plan, "
        "controller.text.job, controller.text.service, controller.runtime.estimation, controller.recording.recorder; "
        "assert 'mujoco' not in sys.modules and 'sim.robot' not in sys.modules, sorted(m for m in sys.modules if 'mujoco' in m)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stderr
