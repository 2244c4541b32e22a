"""An evaluation suite (YAML) and the episodes it crosses into.

A suite names what varies: scenarios, policies, whether the planner is in the loop, trackers, hardware
configs, perturbation conditions (a shipped set by name, or inline values, any of them a range
drawn per episode from its seed), fault drills (plans
of `configs/faults/`, each on the simulated hardware it is written for) and seeds; pass
criteria may hold per condition, and every drill carries its own (what the plan expects). Every
combination is an `EpisodeSpec` with a stable id, so a report lists each episode's seed and result
and an interrupted sweep knows what is done.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hw.emulation.faults import available_fault_plans, load_fault_file
from hw.errors import ConfigError
from hw.shipped import config_dir
from hw.yamlconfig import from_dict, load_yaml, preset_names, resolve_preset
from sim.perturbations import Perturbations, draw_perturbations, has_ranges, perturbation_values


@dataclass(frozen=True)
class Criteria:
    min_survival: float = 0.0  # share of episodes without a fall
    max_velocity_error: float | None = None  # m/s, mean over the condition's episodes


@dataclass(frozen=True)
class SuiteConfig:
    name: str
    duration_s: float  # of every episode
    scenarios: tuple[str, ...] = ("walk_turn_stop",)
    policies: tuple[str, ...] = ("fastsac",)
    planner: tuple[bool, ...] = (False,)
    trackers: tuple[str, ...] = ("default",)  # "default": velocity, or decoupled with the planner; plan followers only with it
    hardware: tuple[str, ...] = ("none",)  # "none": the simulator directly
    perturbations: dict[str, Any] = field(default_factory=lambda: {"nominal": {}})  # label -> a set's name or its values
    faults: tuple[str, ...] = ()  # fault drills: plans by name or path ("all": every plan of configs/faults)
    seeds: int = 3  # seeds first_seed .. first_seed + seeds - 1 per combination
    first_seed: int = 0
    criteria: dict[str, Criteria] = field(default_factory=dict)  # condition label -> what it must meet
    description: str = ""

    def __post_init__(self) -> None:
        if self.duration_s <= 0 or self.seeds < 1 or self.first_seed < 0:
            raise ConfigError("a suite needs duration_s > 0, seeds >= 1 and first_seed >= 0")
        from controller.tracking.registry import PLAN_FOLLOWING, available_trackers  # noqa: PLC0415

        unknown = [t for t in self.trackers if t != "default" and t not in available_trackers()]
        if unknown:
            raise ConfigError(f"unknown trackers {unknown} in the suite (valid: default, {', '.join(available_trackers())})")
        if any(t in PLAN_FOLLOWING for t in self.trackers) and True not in self.planner:
            raise ConfigError(f"trackers {sorted(PLAN_FOLLOWING & set(self.trackers))} follow planned motion: add planner: [true]")


@dataclass(frozen=True)
class EpisodeSpec:
    """One combination of the suite, to run (`runner.run_episode`): its seed and its drawn perturbations."""

    scenario: str
    policy: str
    planner: bool
    hardware: str
    condition: str  # the perturbation label
    perturbations: Perturbations
    seed: int
    duration_s: float
    faults: str | None = None  # a fault plan: this episode is a drill
    tracker: str = "default"
    randomized: bool = False  # the condition gives ranges: `perturbations` were drawn from this episode's seed

    @property
    def group(self) -> str:
        """Everything but the seed: the condition a survival rate is taken over."""
        loop = ("planner" if self.planner else "direct") + (f"+{self.tracker}" if self.tracker != "default" else "")
        return f"{self.scenario}/{self.policy}/{loop}/{self.hardware}/{self.condition}"

    @property
    def id(self) -> str:
        return f"{self.group}/seed{self.seed}"


def available_suites() -> list[str]:
    return preset_names(config_dir("suites"))


def load_suite(name_or_path: str) -> SuiteConfig:
    path = resolve_preset(name_or_path, config_dir("suites"), "suite")
    cfg = from_dict(SuiteConfig, load_yaml(path), str(path))
    episodes(cfg, str(path))  # every condition resolves, every criterion names one
    return cfg


@dataclass(frozen=True)
class _Condition:
    """A perturbation condition as written (ranges undrawn), and where a mistake in it is."""

    values: Any
    source: str
    key: str

    @staticmethod
    def of(label: str, value: Any, source: str) -> _Condition:
        if isinstance(value, str):
            return _Condition(perturbation_values(value), str(resolve_preset(value, config_dir("perturbations"), "perturbation set")), "")
        return _Condition(value or {}, source, f"perturbations.{label}")

    def draw(self, seed: int) -> Perturbations:
        return draw_perturbations(self.values, seed, self.source, self.key)


def fault_plans(cfg: SuiteConfig) -> dict[str, tuple[str, str]]:
    """The suite's drills: label -> the plan (a shipped name, or an absolute path a worker elsewhere can open) and its hardware."""
    shipped = available_fault_plans()
    names = [n for n in cfg.faults if n != "all"] + (shipped if "all" in cfg.faults else [])
    plans = {}
    for name in dict.fromkeys(names):
        plan = name if name in shipped else str(Path(name).resolve())
        plans[Path(name).stem] = (plan, load_fault_file(plan).hardware)
    return plans


def episodes(cfg: SuiteConfig, source: str = "suite") -> list[EpisodeSpec]:
    """Every combination, seeds innermost, in a fixed order: the perturbed conditions, then the drills."""
    conditions = {label: _Condition.of(label, value, source) for label, value in cfg.perturbations.items()}
    drills = fault_plans(cfg)
    clash = sorted(set(conditions) & set(drills))
    if clash:
        raise ConfigError(f"{source}: {', '.join(clash)} is both a perturbation label and a fault plan: rename the label")
    unknown = [label for label in cfg.criteria if label not in conditions and label not in drills]
    if unknown:
        known = ", ".join([*conditions, *drills])
        raise ConfigError(f"{source}: criteria for unknown conditions: {', '.join(unknown)} (conditions: {known})")
    seeds = range(cfg.first_seed, cfg.first_seed + cfg.seeds)
    randomized = {label: has_ranges(condition.values) for label, condition in conditions.items()}
    from controller.tracking.registry import PLAN_FOLLOWING  # noqa: PLC0415

    loops = [(t, p) for t, p in itertools.product(cfg.trackers, cfg.planner) if p or t not in PLAN_FOLLOWING]
    perturbed = [
        EpisodeSpec(
            sc, pol, planner, hw, label, conditions[label].draw(seed), seed, cfg.duration_s, randomized=randomized[label], tracker=t
        )
        for sc, pol, (t, planner), hw, label, seed in itertools.product(cfg.scenarios, cfg.policies, loops, cfg.hardware, conditions, seeds)
    ]
    drilled = [
        EpisodeSpec(sc, pol, planner, drills[label][1], label, Perturbations(), seed, cfg.duration_s, faults=drills[label][0], tracker=t)
        for sc, pol, (t, planner), label, seed in itertools.product(cfg.scenarios, cfg.policies, loops, drills, seeds)
    ]
    if not perturbed and not drilled:
        raise ConfigError(f"{source}: the suite has no episodes: give perturbation conditions or fault plans")
    return perturbed + drilled


def suite_path(name_or_path: str) -> Path:
    return resolve_preset(name_or_path, config_dir("suites"), "suite")
