"""What a run is asked to do: `g1ctl sim` and `g1ctl run` parse into this; the simulator and the real robot both take it.

Apart from `sim_run` so that a run on a real robot (`robot_run`) reads it without importing MuJoCo.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from sim.perturbations import Perturbations


@dataclass(frozen=True)
class SimRunConfig:
    scenario: str = "walk_turn_stop"
    policy: str = "fastsac"
    tracker: str | None = None  # None: "decoupled" with the planner, else "velocity"
    planner: bool = False  # plan whole-body motion from the command (10 Hz replanning) and track the plan
    duration: float | None = None  # None: the scenario's duration
    seed: int = 0
    input: str = "scripted"
    video: Path | None = None
    report: Path | None = None
    plot: Path | None = None  # None: beside the report, as .png
    realtime: bool = False
    viewer: bool = False
    progress: bool = False
    assets_dir: str | None = None
    video_fps: int = 20
    hardware: str | None = None  # a hardware config: drive the sim through its codecs and buses
    faults: str | None = None  # with `hardware`: a YAML of faults to inject per bus
    picture: Path | None = None  # PNG of the final frame
    status: bool = False  # a live status line on stderr (mode, command, measured velocity, plan latency)
    perturbations: Perturbations | None = None  # pushes, friction, payload, motor strength, latency, noise (`sim.perturbations`)
    rt_priority: int = 0  # on a real robot: SCHED_FIFO priority of the run (0: normal scheduling), see hw.realtime
    cpu: int | None = None  # on a real robot: pin the run to this CPU
    estimator: bool = False  # estimate the base position on the simulator too (every other robot always runs the estimator)
    estimator_config: str | None = None  # the estimator's YAML (None: configs/estimator.yaml)
