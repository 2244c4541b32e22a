"""Trackers by name: `--tracker NAME` picks one; an unknown name lists the valid ones."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from controller.assets import Assets
from controller.tracking.tracker import Tracker
from hw.errors import ConfigError


@dataclass(frozen=True)
class TrackerSpec:
    """What a tracker is built from: a policy preset (name or YAML path), the assets, the robot's joints."""

    policy: str
    assets: Assets
    robot_joint_names: tuple[str, ...]


def _velocity(spec: TrackerSpec) -> Tracker:
    from controller.tracking.presets import load_policy  # noqa: PLC0415 - loads onnxruntime only when chosen

    return load_policy(spec.policy, spec.assets, spec.robot_joint_names)


def _decoupled(spec: TrackerSpec) -> Tracker:
    from controller.tracking.decoupled import DecoupledTracker  # noqa: PLC0415
    from controller.tracking.presets import load_policy  # noqa: PLC0415

    return DecoupledTracker(load_policy(spec.policy, spec.assets, spec.robot_joint_names))


def _whole_body(spec: TrackerSpec) -> Tracker:
    """`spec.policy` as a whole-body preset: `wbt_*` or a YAML path as given; a locomotion preset name (the
    default 'fastsac', or 'ppo') picks the whole-body policy trained the same way ('wbt_fastsac', 'wbt_ppo')."""
    from controller.tracking.whole_body import load_whole_body, whole_body_preset  # noqa: PLC0415

    return load_whole_body(whole_body_preset(spec.policy), spec.assets, spec.robot_joint_names)


TRACKERS: dict[str, Callable[[TrackerSpec], Tracker]] = {
    "velocity": _velocity,  # the velocity-command locomotion policy (holosoma's G1 loco policies)
    "decoupled": _decoupled,  # planned motion: legs through the velocity policy, waist and arms from the plan
    "whole-body": _whole_body,  # planned motion: holosoma's whole-body tracking policy on the plan (needs --planner)
}


# The trackers whose `Tracker.needs_plan` is set: they follow planned frames, so they run only with the planner
# (known here, before any is built, for a sweep to cross trackers with the planner on and off).
PLAN_FOLLOWING = frozenset({"whole-body"})


def available_trackers() -> list[str]:
    return sorted(TRACKERS)


def tracker_for(name: str | None, planner: bool) -> str:
    """The tracker a run uses: `name` when given, else the one for its reference (planned motion or the command);
    an unknown name, or a plan-following tracker in a run without the planner, is refused in one line."""
    chosen = name or ("decoupled" if planner else "velocity")
    if chosen not in TRACKERS:
        raise ConfigError(f"unknown tracker '{chosen}' (valid: {', '.join(available_trackers())})")
    if chosen in PLAN_FOLLOWING and not planner:
        raise ConfigError(f"the {chosen} tracker follows planned whole-body motion: add --planner")
    return chosen


def make_tracker(name: str, spec: TrackerSpec) -> Tracker:
    try:
        factory = TRACKERS[name]
    except KeyError:
        raise ConfigError(f"unknown tracker '{name}' (valid: {', '.join(available_trackers())})") from None
    return factory(spec)
