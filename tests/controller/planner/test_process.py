"""The planner in a process of its own: the same plans as in this process, its errors raised here, its end told."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
import pytest

from controller.planner.process import PlannerProcess, PlannerProcessError, planner_cpu
from controller.planner.request import Keyframe, PlanRequest, PlanRequestError, target_root
from controller.planner.runtime import Planner
from controller.reference.buffer import ReferenceBuffer
from controller.reference.locomotion import SmartLocomotion
from controller.reference.scheduler import ReplanScheduler, SchedulerConfig
from hw import g1
from hw.errors import AssetError
from hw.shipped import model_dir
from tests.conftest import wait_for

pytestmark = pytest.mark.skipif(not (model_dir("planner") / "planner.onnx").is_file(), reason="no shipped planner model")


def standing() -> np.ndarray:
    return np.tile(np.array(g1.standing_qpos()), (4, 1))


def test_plans_from_the_process_are_those_of_the_planner_here() -> None:
    request = PlanRequest(standing(), (target_root(43, 10.0, 0.3, 0.5),), (44,), seed=7)
    here = Planner.load().plan(request)
    with PlannerProcess() as process:
        there = process.plan(request)
        np.testing.assert_array_equal(there.qpos, here.qpos)
        np.testing.assert_array_equal(there.contacts, here.contacts)
        assert there.unreachable == here.unreachable is not None  # what the plan says comes back with it
        bad = standing()[-1].copy()
        bad[g1.joint_indices(["left_knee_joint"], qpos=True)[0]] = 3.1
        with pytest.raises(PlanRequestError, match="keyframe at frame 5: left_knee_joint is 3.1000 rad"):
            process.plan(PlanRequest(standing(), (Keyframe(5, bad),), (44,)))
        assert process.plan(request).qpos.shape == (44, 36)  # a refused request leaves the process serving


def test_requests_sent_together_are_answered_each_in_order() -> None:
    requests = [PlanRequest(standing(), (target_root(43, 0.5 * k, 0.0, 0.0),), (44,), seed=k) for k in range(3)]
    planner = Planner.load()
    with PlannerProcess() as process:
        futures = [process.submit(r) for r in requests]  # all sent before the first is back
        for request, future in zip(requests, futures, strict=True):
            np.testing.assert_array_equal(future.result().qpos, planner.plan(request).qpos)


def test_the_scheduler_on_the_real_time_clock_plans_through_the_process() -> None:
    buffer = ReferenceBuffer()
    buffer.reset(np.array(g1.standing_qpos()), 0.0)
    with PlannerProcess() as process:
        scheduler = ReplanScheduler(
            process.plan, SmartLocomotion().request, buffer, SchedulerConfig(), simulated_clock=False, submit=process.submit
        )
        scheduler.update(0.0)
        assert wait_for(lambda: (scheduler.update(0.02), scheduler.counters.replans)[1] == 1)
        assert scheduler.counters.planner_failures == 0 and len(scheduler.plan_latencies_s) == 1
        scheduler.close()


def test_a_process_that_died_or_was_closed_is_an_error_that_says_so() -> None:
    process = PlannerProcess()
    process.plan(PlanRequest(standing(), seed=1))
    os.kill(process._process.pid, signal.SIGKILL)
    with pytest.raises(PlannerProcessError, match=r"the planner process is gone \(killed by SIGKILL\)"):
        process.plan(PlanRequest(standing()))  # sent before the reader saw the end, or refused after: either way, said
    process.close()
    process.close()  # safe twice
    with pytest.raises(PlannerProcessError, match="closed"):
        process.plan(PlanRequest(standing()))


def test_a_planner_that_cannot_load_is_named(tmp_path: Path) -> None:
    with pytest.raises(AssetError, match=f"no planner model in {tmp_path}"):
        PlannerProcess(model_dir=tmp_path)


def test_the_planner_gets_a_cpu_of_its_own_where_there_are_two() -> None:
    assert planner_cpu({0, 1, 2, 3}, None) == 3
    assert planner_cpu({0, 1, 2, 3}, 3) == 2  # never the control loop's
    assert planner_cpu({5}, None) is None and planner_cpu({5}, 5) is None  # one CPU: shared, as the kernel likes


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one CPU: nothing to pin the planner apart from")
def test_a_planner_process_on_a_cpu_runs_there_alone_and_plans_the_same() -> None:
    cpu = max(os.sched_getaffinity(0))
    request = PlanRequest(standing(), (target_root(43, 1.0, 0.3, 0.5),), (44,), seed=3)
    with PlannerProcess(cpu=cpu) as process:
        assert os.sched_getaffinity(process._process.pid) == {cpu}
        np.testing.assert_array_equal(process.plan(request).qpos, Planner.load().plan(request).qpos)


def test_a_cpu_the_planner_may_not_use_is_named() -> None:
    missing = max(os.sched_getaffinity(0)) + 4096
    with pytest.raises(AssetError, match=f"the planner process cannot run on CPU {missing}: "):
        PlannerProcess(cpu=missing)
