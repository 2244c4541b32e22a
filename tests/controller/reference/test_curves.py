"""Curved paths: the sampled geometry, and a follower that walks it continuously on an ideal robot and stops at its end."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.commands.velocity import VelocityCommand
from controller.reference.curves import CurveFollower, sample_path
from controller.reference.waypoints import WaypointConfig
from controller.text.program import Arc, Curve
from hw.errors import ConfigError
from tests.conftest import planar_state as state

FINISH = WaypointConfig(position_tolerance=0.08, stop_radius=0.06, heading_tolerance_deg=4.0, stop_angle_deg=2.5)


@pytest.mark.parametrize("arcs", [[(1.0, 90.0)], [(0.5, -180.0)], [(0.75, 360.0), (0.75, -360.0)], [(2.0, 45.0), (1.0, -90.0)]])
def test_the_sampled_path_ends_where_the_program_says(arcs: list[tuple[float, float]]) -> None:
    start = (1.0, -2.0, math.radians(30.0))
    path = sample_path(start, [(r, math.radians(a)) for r, a in arcs], 0.02)
    end = Curve(tuple(Arc(r, a) for r, a in arcs)).end
    c, s = math.cos(start[2]), math.sin(start[2])
    expected = (start[0] + c * end.forward_m - s * end.left_m, start[1] + s * end.forward_m + c * end.left_m)
    assert path.positions[-1] == pytest.approx(expected, abs=1e-9)
    assert math.degrees(path.headings[-1] - start[2]) == pytest.approx(end.heading_deg, abs=1e-6)
    steps = np.linalg.norm(np.diff(path.positions, axis=0), axis=1)
    assert steps.max() <= 0.021 and path.length_m == pytest.approx(sum(r * math.radians(abs(a)) for r, a in arcs), rel=1e-3)


def _walk(follower: CurveFollower, seconds: float, lag: float = 0.0) -> tuple[list[VelocityCommand], tuple[float, float, float], float]:
    """An ideal robot at 50 Hz that does what it is commanded (after a first-order lag of `lag` s)."""
    x, y, h, t = 0.0, 0.0, 0.0, 0.0
    v = VelocityCommand()
    commands = []
    for _ in range(round(seconds * 50)):
        vw = (v.vx * math.cos(h) - v.vy * math.sin(h), v.vx * math.sin(h) + v.vy * math.cos(h))
        cmd = follower.command(state(t, x, y, math.degrees(h), vw, v.yaw_rate))
        commands.append(cmd)
        a = 1.0 if lag == 0 else 0.02 / lag
        v = VelocityCommand(v.vx + a * (cmd.vx - v.vx), v.vy + a * (cmd.vy - v.vy), v.yaw_rate + a * (cmd.yaw_rate - v.yaw_rate))
        x, y, h, t = x + vw[0] * 0.02, y + vw[1] * 0.02, h + v.yaw_rate * 0.02, t + 0.02
        if follower.done:
            break
    return commands, (x, y, h), t


def test_a_circle_is_walked_without_stopping_and_ends_at_rest_on_its_start() -> None:
    follower = CurveFollower((0.0, 0.0, 0.0), [(0.75, 2 * math.pi)], 0.5, FINISH)
    commands, (x, y, h), t = _walk(follower, 30.0, lag=0.15)
    assert follower.done and math.hypot(x, y) < 0.08 and math.degrees(h) == pytest.approx(360.0, abs=4.0)
    moving = commands[: round(0.8 * len(commands))]
    assert min(c.vx for c in moving[25:]) > 0.35  # continuous, no stop-and-go
    assert np.mean([c.yaw_rate for c in moving[25:]]) == pytest.approx(0.5 / 0.75, rel=0.1)
    assert follower.max_cross_track_m < 0.1 and t < 2 * math.pi * 0.75 / 0.5 + 4.0


def test_a_figure_eight_changes_its_turning_side_and_never_skips_where_it_crosses_itself() -> None:
    follower = CurveFollower((0.0, 0.0, 0.0), [(0.6, 2 * math.pi), (0.6, -2 * math.pi)], 0.5, FINISH)
    commands, (x, y, h), _ = _walk(follower, 40.0, lag=0.15)
    assert follower.done and math.hypot(x, y) < 0.08 and math.degrees(h) == pytest.approx(0.0, abs=4.0)
    yaw = [c.yaw_rate for c in commands]
    assert max(yaw) > 0.6 and min(yaw) < -0.6
    assert follower.path.length_m == pytest.approx(4 * math.pi * 0.6, rel=1e-3)
    assert follower.report()["curve_length_m"] == pytest.approx(7.54, abs=0.01)


def test_the_planner_gets_the_same_curve_from_where_the_plan_is() -> None:
    follower = CurveFollower((0.0, 0.0, 0.0), [(1.0, math.pi / 2)], 0.5, FINISH)
    qpos = np.zeros(36)
    qpos[3] = 1.0  # identity quaternion, at the start
    cmd = follower.plan_command(qpos)
    assert (cmd.vx, cmd.vy, cmd.yaw_rate) == pytest.approx((0.5, 0.0, 0.5), abs=1e-6)


def test_bad_curves_are_refused() -> None:
    with pytest.raises(ConfigError, match="at least one arc"):
        CurveFollower((0.0, 0.0, 0.0), [], 0.5, FINISH)
