from __future__ import annotations

from pathlib import Path

import pytest

from controller.commands.velocity import CommandLimits
from controller.inputs.scripted import ScriptedSource, available_scenarios, load_scenario, timeline
from hw.errors import ConfigError


def test_shipped_scenarios() -> None:
    assert {"walk_turn_stop", "random_commands"} <= set(available_scenarios())
    wts = load_scenario("walk_turn_stop")
    assert wts.duration == 20.0
    labels = [s.label for s in wts.steps]
    assert labels[0] == "stand" and labels[-1] == "stop"
    assert any(s.vx > 0 for s in wts.steps) and any(s.vx < 0 for s in wts.steps)
    assert any(s.yaw_rate != 0 for s in wts.steps) and any(s.vy != 0 for s in wts.steps)


def test_unknown_scenario_lists_available() -> None:
    with pytest.raises(ConfigError, match="unknown scenario 'walk_trun'.*walk_turn_stop"):
        load_scenario("walk_trun")


def test_random_timeline_is_seeded_within_limits_with_zero_share() -> None:
    limits = CommandLimits(vx=(-0.5, 1.0), vy=(-0.3, 0.3), yaw_rate=(-1.0, 1.0))
    scenario = load_scenario("random_commands")
    steps = timeline(scenario, 300.0, limits, seed=1)
    assert steps == timeline(scenario, 300.0, limits, seed=1)
    assert steps != timeline(scenario, 300.0, limits, seed=2)
    assert len(steps) == 151
    assert all(-0.5 <= s.vx <= 1.0 and -0.3 <= s.vy <= 0.3 for s in steps)
    zero_share = sum(s.label == "zero" for s in steps[1:]) / (len(steps) - 1)
    assert 0.1 < zero_share < 0.3


def test_scripted_source_holds_each_step_until_the_next() -> None:
    source = ScriptedSource(load_scenario("walk_turn_stop").steps, CommandLimits(vx=(-0.3, 0.3)))
    assert source.poll(0.5).velocity.is_zero()
    assert source.poll(1.0).velocity.vx == 0.3  # clamped to the limits
    assert source.poll(6.0).velocity.yaw_rate == 0.6
    assert source.poll(19.9).velocity.is_zero()


@pytest.mark.parametrize(("value", "key"), [(".nan", "x"), (".inf", "y"), ("-.inf", "heading_deg")])
def test_a_waypoint_that_is_not_finite_is_refused_naming_it(value: str, key: str, tmp_path: Path) -> None:
    pose = {"x": "1.0", "y": "0.0", "heading_deg": "0.0"} | {key: value}
    path = tmp_path / "bad.yaml"
    path.write_text("duration: 10\nwaypoints:\n  - {x: 0.5, y: 0.0}\n  - {" + ", ".join(f"{k}: {v}" for k, v in pose.items()) + "}\n")
    with pytest.raises(ConfigError) as caught:
        load_scenario(str(path))
    message = str(caught.value)
    assert "waypoints[1]" in message and f"waypoint {key} is" in message and "\n" not in message
