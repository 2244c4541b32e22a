"""The replanning scheduler with the shipped planner: plans spliced on time, and every fault drill counted."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from controller.commands.velocity import VelocityCommand
from controller.planner.request import Plan, PlanRequest
from controller.planner.runtime import Planner
from controller.reference.buffer import ReferenceBuffer
from controller.reference.locomotion import SmartLocomotion
from controller.reference.scheduler import ReplanScheduler, SchedulerConfig
from hw import g1, quat
from hw.errors import ConfigError
from hw.shipped import model_dir
from tests.conftest import HANG_S, wait_for

pytestmark = pytest.mark.skipif(not (model_dir("planner") / "planner.onnx").is_file(), reason="no shipped planner model")

TICK = 1 / 50


@pytest.fixture(scope="module")
def planner() -> Planner:
    shipped = Planner.load()
    shipped.warm_up()
    return shipped


def make(plan, cfg: SchedulerConfig | None = None, limits=None):  # type: ignore[no-untyped-def]
    buffer = ReferenceBuffer()
    buffer.reset(np.array(g1.standing_qpos()), 0.0)
    locomotion = SmartLocomotion(seed=3)
    locomotion.command = VelocityCommand(vx=0.5)
    return ReplanScheduler(plan, locomotion.request, buffer, cfg or SchedulerConfig(), simulated_clock=True, joint_limits=limits), buffer


def run_ticks(scheduler: ReplanScheduler, seconds: float) -> None:
    for k in range(round(seconds / TICK)):
        scheduler.update(k * TICK)


def test_plans_arrive_at_ten_hertz_and_walk_the_reference_forward(planner: Planner) -> None:
    scheduler, buffer = make(planner.plan)
    run_ticks(scheduler, 3.0)
    c = scheduler.counters
    assert c.replans >= 28 and c.late_plans == 0 and c.planner_failures == 0  # 10 Hz for 3 s
    assert len(scheduler.plan_latencies_s) == c.requests or len(scheduler.plan_latencies_s) == c.requests - 1
    x = buffer.sample(3.0).qpos[0]
    assert 0.6 < x < 1.6  # 0.5 m/s forward, from standing, springing up to speed
    scheduler.close()


def test_the_same_seed_gives_the_same_reference_whatever_the_machine(planner: Planner) -> None:
    def slow_plan(request: PlanRequest) -> Plan:
        time.sleep(0.01)  # a slower machine: the plan still counts as ready at its simulated latency
        return planner.plan(request)

    first, a = make(planner.plan)
    second, b = make(slow_plan)
    run_ticks(first, 1.0)
    run_ticks(second, 1.0)
    np.testing.assert_array_equal(a.sample(1.0).qpos, b.sample(1.0).qpos)
    first.close()
    second.close()


@pytest.mark.parametrize("drill", ["raises", "nan", "wrong_shape", "tilted", "sunk"])
def test_a_failing_planner_is_counted_and_the_reference_holds_a_pose(planner: Planner, drill: str) -> None:
    calls = {"n": 0}

    def plan(request: PlanRequest) -> Plan:
        calls["n"] += 1
        good = planner.plan(request)
        if calls["n"] <= 5:
            return good
        if drill == "raises":
            raise RuntimeError("injected planner fault")
        if drill == "nan":
            return Plan(np.full_like(good.qpos, np.nan), good.contacts, good.latency_ms)
        if drill in ("tilted", "sunk"):
            bad = np.array(good.qpos)
            if drill == "tilted":  # past its side: 120 degrees about x
                bad[:, g1.QPOS_ROOT_QUAT] = (np.cos(np.pi / 3), np.sin(np.pi / 3), 0.0, 0.0)
            else:
                bad[20:, 2] -= 0.6
            return Plan(bad, good.contacts, good.latency_ms)
        return Plan(good.qpos[:, :30], good.contacts, good.latency_ms)

    scheduler, buffer = make(plan)
    run_ticks(scheduler, 3.0)
    c = scheduler.counters
    assert c.replans == 5 and c.planner_failures >= 20
    assert scheduler.last_failure is not None
    if drill in ("tilted", "sunk"):
        assert ("tilted 120 degrees" if drill == "tilted" else "height moved 0.6") in scheduler.last_failure
    end = buffer.sample(3.0)
    assert end.held and np.isfinite(end.qpos).all()  # the last plan ran out: its last pose, held
    scheduler.close()


def test_a_stalled_planner_is_a_failure_and_a_fresh_worker_takes_over(planner: Planner) -> None:
    release, returned = threading.Event(), threading.Event()
    calls = {"n": 0}

    def plan(request: PlanRequest) -> Plan:
        calls["n"] += 1
        if calls["n"] == 3:
            release.wait(HANG_S)  # stalls until the test releases it
            returned.set()
        return planner.plan(request)

    scheduler, _ = make(plan, SchedulerConfig(stall_timeout_s=1.0))  # a plan takes milliseconds: only the stalled one runs over
    run_ticks(scheduler, 2.0)
    assert not returned.is_set()  # the run went on without waiting for the stalled plan
    release.set()
    assert scheduler.counters.planner_failures == 1 and "stalled" in str(scheduler.last_failure)
    assert scheduler.counters.replans >= 15  # planning went on after the stall
    scheduler.close()


def test_a_plan_slower_than_its_lookahead_is_late_on_the_real_time_clock(planner: Planner) -> None:
    def slow_plan(request: PlanRequest) -> Plan:
        time.sleep(0.06)  # a plan that costs more than the 40 ms look-ahead: late whatever the machine
        return planner.plan(request)

    buffer = ReferenceBuffer()
    buffer.reset(np.array(g1.standing_qpos()), 0.0)
    cfg = SchedulerConfig(lookahead_s=0.04, simulated_latency_s=0.0)
    scheduler = ReplanScheduler(slow_plan, SmartLocomotion().request, buffer, cfg, simulated_clock=False)
    start = time.perf_counter()

    def three_late_plans() -> bool:
        scheduler.update(time.perf_counter() - start)  # a control tick every 5 ms
        return scheduler.counters.late_plans >= 3

    assert wait_for(three_late_plans)
    assert scheduler.counters.replans == 0
    scheduler.close()


def test_plans_are_clamped_to_the_joint_limits_and_what_was_beyond_them_is_counted(planner: Planner) -> None:
    lower, upper = np.full(g1.NUM_JOINTS, -0.05), np.full(g1.NUM_JOINTS, 0.05)
    beyond = {"n": 0}

    def plan(request: PlanRequest) -> Plan:
        good = planner.plan(request)
        joints = good.qpos[:, g1.QPOS_JOINTS]
        beyond["n"] += int(((joints < lower) | (joints > upper)).sum())
        return good

    scheduler, buffer = make(plan, limits=(lower, upper))
    run_ticks(scheduler, 1.0)
    assert scheduler.counters.joint_values_beyond_limits == beyond["n"] > 0  # every plan that came back, before the clamp
    joints = buffer.sample(1.0).qpos[g1.QPOS_JOINTS]
    assert (joints >= -0.05 - 1e-9).all() and (joints <= 0.05 + 1e-9).all()
    scheduler.close()


def test_wild_frames_and_targets_out_of_reach_are_counted_on_every_plan(planner: Planner) -> None:
    calls = {"n": 0}

    def plan(request: PlanRequest) -> Plan:
        calls["n"] += 1
        good = planner.plan(request)
        if calls["n"] % 2:
            return good
        bad = np.array(good.qpos)
        bad[30:35, g1.QPOS_ROOT_QUAT] = quat.from_axis_angle([0.0, 1.0, 0.0], np.radians(70.0))  # wild, short of a failure
        return Plan(bad, good.contacts, good.latency_ms, unreachable="the keyframe at frame 43 is 10.00 m away")

    scheduler, _ = make(plan)
    run_ticks(scheduler, 2.0)
    c = scheduler.counters
    assert c.planner_failures == 0 and c.requests >= 20 and c.planned_frames == 44 * (c.replans + c.late_plans)
    assert c.wild_frames == 5 * (c.requests // 2) and c.unreachable_targets == c.requests // 2
    scheduler.close()


def test_a_plans_latency_on_the_real_time_clock_ends_when_it_is_back_not_when_a_tick_takes_it(planner: Planner) -> None:
    back = threading.Event()

    def plan(request: PlanRequest) -> Plan:
        good = planner.plan(request)
        back.set()
        return good

    buffer = ReferenceBuffer()
    buffer.reset(np.array(g1.standing_qpos()), 0.0)
    scheduler = ReplanScheduler(plan, SmartLocomotion().request, buffer, SchedulerConfig(), simulated_clock=False)
    asked = time.perf_counter()
    scheduler.update(0.0)
    assert back.wait(HANG_S)
    time.sleep(0.2)  # the next control tick comes late
    taken = time.perf_counter()
    scheduler.update(0.02)
    assert scheduler.counters.replans == 1 and len(scheduler.plan_latencies_s) == 1
    assert scheduler.plan_latencies_s[0] < taken - asked - 0.2  # the wait for the tick is not the plan's
    scheduler.close()


def test_config_mistakes_name_the_field() -> None:
    with pytest.raises(ConfigError, match="period_s"):
        SchedulerConfig(period_s=0.0)
    with pytest.raises(ConfigError, match="always late"):
        SchedulerConfig(lookahead_s=0.05, simulated_latency_s=0.06)
    with pytest.raises(ConfigError, match="max_root_height_change_m"):
        SchedulerConfig(max_root_height_change_m=0.0)


def test_a_dead_worker_is_counted_and_replaced(planner: Planner) -> None:
    scheduler, _ = make(planner.plan)
    run_ticks(scheduler, 0.5)
    scheduler._executor.shutdown(wait=True)  # the worker dies under the scheduler
    for k in range(25, 75):
        scheduler.update(k * TICK)
    assert scheduler.counters.planner_failures == 1 and "worker is gone" in str(scheduler.last_failure)
    assert scheduler.counters.replans >= 8  # a fresh worker took over
    scheduler.close()
