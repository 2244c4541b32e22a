"""`g1ctl bench estimator`: which cases run where, and its one-line refusals (the runs themselves: tests/cli/test_sim_estimator.py)."""

from __future__ import annotations

import pytest

from controller.bench.estimator import CASES, select_cases
from hw.errors import ConfigError


def test_perturbations_stay_off_the_dds_robot_and_faults_off_the_simulator() -> None:
    pairs = {(case.name, where) for case, where in select_cases(["sim", "sim-can", "sim-dds"], None)}
    assert ("drill_push", "sim-can") in pairs and ("drill_push", "sim") in pairs and ("drill_push", "sim-dds") not in pairs
    assert ("drill_imu_bias", "sim-can") in pairs and ("drill_imu_bias", "sim") not in pairs
    assert all((case.name, "sim-can") in pairs for case in CASES)


def test_unknown_cases_and_real_robots_are_refused_in_one_line() -> None:
    with pytest.raises(ConfigError, match="--cases: unknown nope; known: walk_turn_stop"):
        select_cases(["sim"], ["nope"])
    with pytest.raises(ConfigError, match="'g1-dds' is a real robot; the benchmark needs a simulator's truth"):
        select_cases(["g1-dds"], None)
