"""Scripted command timelines (scenarios) from YAML, fixed or seeded-random."""

from __future__ import annotations

import bisect
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from controller.commands.gestures import GESTURE_LABELS
from controller.commands.velocity import CommandLimits, VelocityCommand
from controller.commands.waypoints import WorldWaypoint
from controller.inputs.base import CommandSample, CommandSource
from hw.errors import ConfigError
from hw.shipped import config_dir
from hw.yamlconfig import load_config, preset_names


@dataclass(frozen=True)
class ScenarioStep:
    """From time `t` (s) on, command this velocity (and this upper-body gesture) until the next step."""

    t: float
    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0
    label: str = ""
    gesture: str = ""  # one of commands.gestures.GESTURE_LABELS (not "none"); "" for none

    def __post_init__(self) -> None:
        if self.gesture and (self.gesture not in GESTURE_LABELS or self.gesture == "none"):
            raise ValueError(f"unknown gesture '{self.gesture}' (valid: {', '.join(g for g in GESTURE_LABELS if g != 'none')})")


@dataclass(frozen=True)
class RandomProgram:
    """A new command every `interval` s, uniform within the policy's ranges, `zero_fraction` of them zero."""

    interval: float = 2.0
    zero_fraction: float = 0.2
    settle: float = 1.0  # standing time before the first random command

    def __post_init__(self) -> None:
        if self.interval <= 0:
            raise ValueError(f"random.interval must be positive, got {self.interval}")
        if not 0.0 <= self.zero_fraction <= 1.0:
            raise ValueError(f"random.zero_fraction must be within [0, 1], got {self.zero_fraction}")


@dataclass(frozen=True)
class Scenario:
    duration: float
    description: str = ""
    steps: tuple[ScenarioStep, ...] = ()
    random: RandomProgram | None = None
    waypoints: tuple[WorldWaypoint, ...] = ()  # go to each in order, settling at each (planner runs); steps may add gestures

    def __post_init__(self) -> None:
        if self.duration <= 0:
            raise ValueError(f"duration must be positive, got {self.duration}")
        if self.random is not None and (self.steps or self.waypoints):
            raise ValueError("'random' goes alone: no 'steps' or 'waypoints' with it")
        if self.random is None and not (self.steps or self.waypoints):
            raise ValueError("give 'steps', 'random' or 'waypoints'")
        times = [s.t for s in self.steps]
        if times and (times[0] != 0.0 or times != sorted(times)):
            raise ValueError("steps must start at t: 0 and be in time order")


def available_scenarios() -> list[str]:
    return preset_names(config_dir("scenarios"))


def load_scenario(name_or_path: str) -> Scenario:
    """A shipped scenario by name, or a YAML file by path."""
    path = Path(name_or_path)
    if not (path.suffix in (".yaml", ".yml") and path.is_file()):
        path = config_dir("scenarios") / f"{name_or_path}.yaml"
        if not path.is_file():
            raise ConfigError(
                f"unknown scenario '{name_or_path}' (available: {', '.join(available_scenarios())}, or a path to a .yaml file)"
            )
    return load_config(Scenario, path)


def timeline(scenario: Scenario, duration: float, limits: CommandLimits, seed: int) -> tuple[ScenarioStep, ...]:
    """The concrete steps of a scenario over `duration` s: fixed steps as given, random ones drawn from `seed`."""
    if scenario.random is None:
        return scenario.steps
    prog = scenario.random
    rng = np.random.default_rng(seed)
    steps = [ScenarioStep(t=0.0, label="stand")]
    t = prog.settle
    while t < duration:
        if rng.random() < prog.zero_fraction:
            steps.append(ScenarioStep(t=t, label="zero"))
        else:
            steps.append(
                ScenarioStep(
                    t=t,
                    vx=float(rng.uniform(*limits.vx)),
                    vy=float(rng.uniform(*limits.vy)),
                    yaw_rate=float(rng.uniform(*limits.yaw_rate)),
                    label="random",
                )
            )
        t += prog.interval
    return tuple(steps)


class ScriptedSource(CommandSource):
    """Plays a timeline of steps on the run loop's clock."""

    def __init__(self, steps: tuple[ScenarioStep, ...], limits: CommandLimits | None = None) -> None:
        self.steps = steps or (ScenarioStep(t=0.0, label="stand"),)
        self._times = [s.t for s in self.steps]
        commands = (VelocityCommand(s.vx, s.vy, s.yaw_rate) for s in self.steps)
        self._samples = [
            CommandSample(velocity=limits.clamp(c) if limits else c, gesture=s.gesture) for c, s in zip(commands, self.steps, strict=True)
        ]

    def step_index(self, now: float) -> int:
        return max(bisect.bisect_right(self._times, now + 1e-9) - 1, 0)

    def poll(self, now: float) -> CommandSample:
        return self._samples[self.step_index(now)]
