"""`g1ctl plan --hardware` with a real robot's config: the text plan runs on the registry's `real-dds` backend, no simulator.

As in test_run_robot.py, the G1 is `g1ctl robot --dds` started by hand and the config a copy of
`g1-dds.yaml` pointed at loopback: the run knows nothing of a simulator, so only the controller's
own view measures the plan. The stand-in hangs in its gantry, as a robot does at its first runs:
what is tested is the job on a robot, not balance on a wall clock that a loaded machine skips
(standing free, 1 run in 6 fell at 0.9 s beside other test runs: 16 late bus cycles).
"""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")

from tests.conftest import a_robot_config, g1ctl


@pytest.mark.slow
def test_plan_runs_on_a_robot_that_answers_measured_by_its_own_view(tmp_path: Path, claim_dds_domain: Callable[[], int]) -> None:
    domain = claim_dds_domain()
    robot = subprocess.Popen(
        [sys.executable, "-m", "controller.cli", "robot", "--dds", "--domain", str(domain), "--duration", "60", "--gantry"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        report_path = tmp_path / "plan.json"
        config = a_robot_config(tmp_path, domain)
        # No correction: hanging in the gantry the detector saw the wave in 1 of 2 runs (below), and a wave not seen is held on.
        result = g1ctl(
            "plan", "wave with your right hand", "--hardware", str(config), "--report", str(report_path), "--max-corrections", "0"
        )
        assert result.returncode == 0, result.stderr
    finally:
        robot.send_signal(signal.SIGTERM)
        _, err = robot.communicate(timeout=20)
    assert robot.returncode == 0, err
    report = json.loads(report_path.read_text())
    assert report["measured_by"] == "estimate" and report["falls"] == 0
    keys = set(report) | {key for clause in report["clauses"] for key in clause}
    assert not [key for key in keys if key.endswith("_estimate")]  # nothing to set beside the controller's view
    (wave,) = report["clauses"]
    # The clause ran its 3 s and ended. Its gesture is judged through sim-can (test_plan_cli.py): hanging in the gantry the
    # detector, tuned on a robot that stands, saw the wave in 1 of 2 runs here.
    assert wave["end_s"] - wave["start_s"] == pytest.approx(3.0, abs=0.1) and not wave["timed_out"]
    # Hanging in the gantry the legs step in the air while the IMU stays still: the state estimator gives up on its
    # position ("feet slipping"), and a wave, which walks to no position, goes on; the displacement is its last estimate.
    assert len(wave["displacement"]) == 2 and all(math.isfinite(v) for v in wave["displacement"])
    assert report["run"]["estimator"]["updates"] > 100 and "judged_by" not in report["run"]["estimator"]
    run = report["run"]
    assert run["hardware"].endswith("my-g1.yaml") and run["backend"] == "real-dds"  # a robot: no simulator behind it
    assert run["input"] == "unitree-remote"  # the robot's remote in hand
    assert run["final_mode"] == "run" and run["hw"]["faults"] == 0
    assert run["run_seconds"] < 3.0 + 2.5  # the wave's 3 s and the settling: the job ended the run, not its budget (10.5 s)
