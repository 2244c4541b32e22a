"""The waypoints mode: the follower's logic on synthetic states, the shipped scenario, and one run in the loop."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from controller.commands.velocity import CommandLimits, VelocityCommand
from controller.commands.waypoints import WorldWaypoint
from controller.inputs.scripted import load_scenario
from controller.planner.request import Plan, PlanRequest
from controller.reference.planned import PlannedReference, PlannedReferenceConfig
from controller.reference.root_spring import SpringConfig, no_overshoot_gain
from controller.reference.waypoints import WaypointConfig, WaypointFollower, WaypointReference
from hw import g1
from hw.errors import ConfigError
from hw.shipped import model_dir
from tests.conftest import planar_state as state

CFG = WaypointConfig()
HOLD = CFG.settle_hold_s


def follower(*targets: tuple[float, float, float], **kwargs: float) -> WaypointFollower:
    return WaypointFollower([WorldWaypoint(x, y, h) for x, y, h in targets], replace(CFG, **kwargs))


def hold_still(f: WaypointFollower, t0: float, x: float, y: float, heading_deg: float, seconds: float) -> VelocityCommand:
    """At rest at one pose for `seconds` of 50 Hz ticks; the last command."""
    cmd = VelocityCommand()
    for k in range(round(seconds * 50) + 1):
        cmd = f.command(state(t0 + k / 50, x, y, heading_deg))
    return cmd


def test_walks_at_the_target_and_slows_near_it() -> None:
    f = follower((3.0, 0.0, 0.0))
    far = f.command(state(0.0, 0.0, 0.0))
    assert (far.vx, far.vy, far.yaw_rate) == pytest.approx((CFG.max_speed, 0.0, 0.0))
    near = f.command(state(0.02, 2.8, 0.0))
    assert (near.vx, near.vy) == pytest.approx((CFG.max_speed * 0.2 / CFG.slow_radius, 0.0))
    # Close by, the policy would not move for a command of a few cm/s: the floor.
    assert f.command(state(0.04, 2.93, 0.0)).vx == pytest.approx(CFG.min_speed)
    # A target to the left, facing +x: walks left (heading frame) and turns towards it.
    left = follower((0.0, 3.0, 90.0)).command(state(0.0, 0.0, 0.0))
    assert left.vx == pytest.approx(0.0, abs=1e-12) and left.vy == pytest.approx(CFG.max_speed) and left.yaw_rate > 0


def test_the_command_is_clamped_to_the_policy_ranges() -> None:
    f = WaypointFollower([WorldWaypoint(3.0, 0.0)], CFG, CommandLimits(vx=(-0.3, 0.3)))
    assert f.command(state(0.0, 0.0, 0.0)).vx == 0.3


def test_turns_to_the_target_heading_on_the_spot_with_a_floor_and_a_stop_band() -> None:
    f = follower((1.0, 1.0, 10.0))
    assert f.command(state(0.0, 1.0, 1.0, 0.0)).yaw_rate == pytest.approx(CFG.max_yaw_rate * math.radians(10) / CFG.slow_angle)
    assert f.command(state(0.02, 1.0, 1.0, 8.0)).yaw_rate == pytest.approx(CFG.min_yaw_rate)  # 2 degrees: the floor
    assert f.command(state(0.04, 1.0, 1.0, 9.0)).yaw_rate == 0.0  # inside the stop band


def test_the_stop_band_holds_through_the_stops_carry_and_retries_from_rest() -> None:
    f = follower((1.0, 0.0, 0.0))
    assert f.command(state(0.0, 0.9, 0.0, v=(0.1, 0.0))).vx > 0
    assert f.command(state(0.02, 0.97, 0.0, v=(0.1, 0.0))).is_zero()  # 3 cm short: stop, the carry does the rest
    # The stop carries it past, outside the tolerance: still stopped while it moves ...
    assert f.command(state(0.04, 1.06, 0.0, v=(0.08, 0.0))).is_zero()
    # ... and walking back at the floor speed once it has come to rest there.
    cmd = hold_still(f, 0.06, 1.06, 0.0, 0.0, HOLD)
    assert cmd.vx == pytest.approx(-CFG.min_speed) and f.index == 0
    # Pushed far beyond the tolerance: walks back at once, at rest or not.
    g = follower((1.0, 0.0, 0.0))
    g.command(state(0.0, 0.98, 0.0, v=(0.1, 0.0)))
    assert g.command(state(0.02, 1.12, 0.0, v=(0.3, 0.0))).vx < 0


def test_settles_only_on_target_and_at_rest_for_the_hold_then_moves_on() -> None:
    f = follower((1.0, 0.0, 0.0), (1.0, 1.0, 90.0))
    f.start(state(0.0, 0.0, 0.0))
    for k in range(50):  # on target but still walking through it
        f.command(state(1.0 + k / 50, 1.0, 0.0, v=(0.3, 0.0)))
    assert f.index == 0
    hold_still(f, 2.0, 1.07, 0.0, 0.0, 1.0)  # at rest, 7 cm off: not there
    assert f.index == 0
    hold_still(f, 4.0, 1.0, 0.0, 4.0, 1.0)  # at rest, 4 degrees off: not there
    assert f.index == 0
    f.command(state(5.98, 1.03, 0.0, 2.0, yaw_rate=0.5))  # turning onto it ...
    f.command(state(6.0, 1.03, 0.0, 2.0))  # ... at rest from here
    f.command(state(6.0 + HOLD - 0.02, 1.03, 0.0, 2.0))
    assert f.index == 0  # not yet held long enough
    cmd = f.command(state(6.0 + HOLD, 1.03, 0.0, 2.0))
    assert f.index == 1 and cmd.vy > 0  # the next target, to the left
    assert f.errors[0].position_m == pytest.approx(0.03) and f.errors[0].heading_deg == pytest.approx(2.0)


def test_commands_zero_after_the_last_and_reports_errors_and_time() -> None:
    f = follower((0.5, 0.0, 0.0))
    f.start(state(10.0, 0.0, 0.0))
    assert f.report() == {"waypoints_reached": 0, "waypoint_errors": [], "waypoint_time_s": None}
    f.command(state(12.0, 0.49, 0.0, -1.0))
    cmd = f.command(state(12.0 + HOLD, 0.49, 0.0, -1.0))
    assert f.done and cmd.is_zero()
    assert f.command(state(13.0, 0.0, 0.0)).is_zero()  # done: pushed away, it stays put
    report = f.report()
    assert report["waypoints_reached"] == 1 and report["waypoint_time_s"] == pytest.approx(2.0 + HOLD)
    assert report["waypoint_errors"] == [{"position_m": pytest.approx(0.01), "heading_deg": pytest.approx(1.0)}]


def test_a_restart_after_a_fall_keeps_the_progress_and_the_start_time() -> None:
    f = follower((0.5, 0.0, 0.0), (1.0, 0.0, 0.0))
    f.start(state(1.0, 0.0, 0.0))
    hold_still(f, 2.0, 0.5, 0.0, 0.0, 1.0)
    f.start(state(5.0, 0.0, 0.0))
    assert f.index == 1 and f.start_time == 1.0


def test_settings_and_states_that_cannot_work_are_refused() -> None:
    with pytest.raises(ConfigError, match="max_speed"):
        WaypointConfig(max_speed=0.0)
    with pytest.raises(ConfigError, match="stop band"):
        WaypointConfig(stop_radius=0.06)
    with pytest.raises(ConfigError, match="at least one"):
        WaypointFollower([])
    with pytest.raises(ConfigError, match="base position"):
        follower((1.0, 0.0, 0.0)).start(replace(state(0.0, 0.0, 0.0), has_base_position=False))


def test_the_reference_without_planner_follows_the_follower_not_the_supervised_command() -> None:
    ref = WaypointReference(follower((2.0, 0.0, 0.0)))
    ref.start(state(0.0, 0.0, 0.0))
    window = ref.window(state(0.0, 0.0, 0.0), VelocityCommand())
    assert window.velocity.vx == pytest.approx(CFG.max_speed) and window.plan is None
    assert ref.report()["waypoints_reached"] == 0
    held = ref.window(state(0.02, 0.0, 0.0), VelocityCommand(), hold=True)  # the stop button: the waypoints wait
    assert held.velocity.is_zero()


def test_the_plan_walks_to_the_target_from_where_the_plan_is_without_floor_or_stop_band() -> None:
    f = follower((3.0, 0.0, 0.0))
    slow_radius = CFG.max_speed / no_overshoot_gain(SpringConfig().velocity_halflife)  # 0.88 m at 0.6 m/s
    plan = np.array(g1.standing_qpos())
    assert f.plan_command(plan).vx == pytest.approx(CFG.max_speed)
    plan[0] = 2.6
    assert f.plan_command(plan).vx == pytest.approx(CFG.max_speed * 0.4 / slow_radius)
    plan[0] = 2.98
    assert f.plan_command(plan).vx == pytest.approx(CFG.max_speed * 0.02 / slow_radius)  # below the robot's floor
    assert f.command(state(0.0, 2.98, 0.0)).is_zero()  # where the robot stands still


def test_the_planned_reference_gives_the_legs_the_robots_command_and_the_planner_the_plans() -> None:
    def hold_pose(request: PlanRequest) -> Plan:  # a planner that stands where the context ends
        n = request.lengths[0]
        return Plan(np.repeat(request.context[-1:], n, axis=0), np.ones((n, 2), dtype=bool), 0.0)

    f = follower((1.5, 0.0, 0.0))
    no_resync = PlannedReferenceConfig(resync_distance_m=math.inf, resync_heading_rad=math.inf)
    ref = PlannedReference(hold_pose, no_resync, follower=f)
    try:
        ref.start(state(0.0, 0.0, 0.0))  # the plan holds the start pose
        window = ref.window(state(0.02, 1.2, 0.0), VelocityCommand())  # the robot walked on, 0.3 m short
        assert window.velocity.vx == pytest.approx(CFG.max_speed * 0.3 / CFG.slow_radius) and window.plan is not None
        assert ref.locomotion.command.vx == pytest.approx(CFG.max_speed)  # the plan, 1.5 m short, walks at full speed
        assert ref.report()["waypoints_reached"] == 0 and "replans" in ref.report()
    finally:
        ref.close()
    resynced = PlannedReference(hold_pose, follower=follower((1.5, 0.0, 0.0)))
    try:  # with the default resync the plan is moved towards the robot, tick by tick, until it is on it
        resynced.start(state(0.0, 0.0, 0.0))
        xs = [resynced.window(state(0.02 * k, 1.2, 0.0), VelocityCommand()).plan.qpos[0] for k in range(100)]  # type: ignore[union-attr]
        assert resynced.report()["plan_resyncs"] == 1
        assert 0.0 < xs[5] < 0.1 and xs[-1] == pytest.approx(1.2, abs=0.02)  # no jump: under 1 m/s
    finally:
        resynced.close()


def test_the_shipped_scenario_is_a_square_of_poses_back_to_the_start() -> None:
    scenario = load_scenario("waypoints")
    assert not scenario.steps and scenario.random is None and scenario.duration >= 35.0
    points = [(w.x, w.y) for w in scenario.waypoints]
    assert points == [(1.5, 0.0), (1.5, 1.5), (0.0, 1.5), (0.0, 0.0)]  # the robot starts at the origin, facing +x
    assert scenario.waypoints[-1].heading_deg == 0.0
    assert len({w.heading_deg for w in scenario.waypoints}) == 4


@pytest.mark.slow
@pytest.mark.skipif(not (model_dir("planner") / "planner.onnx").is_file(), reason="no shipped planner model")
def test_the_square_with_the_planner_in_the_loop() -> None:
    from controller.runtime.driver import run  # MuJoCo and the planner: this test only
    from controller.runtime.run_config import RunConfig

    report = run(RunConfig(scenario="waypoints", planner=True, duration=36.0))
    assert report["falls"] == 0 and report["planner_failures"] == 0
    assert report["waypoints_reached"] == 4
    for error in report["waypoint_errors"]:
        assert error["position_m"] <= 0.10 and error["heading_deg"] <= 5.0
    assert report["waypoint_time_s"] <= 35.0
