"""What a run is asked to do: `g1ctl sim`, `g1ctl run`, the benchmarks, the sweeps and the text planner fill this in.

`RunConfig` holds names and options as given; `run_plan.resolve_run` checks them and loads what they
name into the plan of the run, which the driver (`runtime/driver.py`) builds and drives, on the
simulator or on a robot alike. `RunHooks` is what a job built on a run adds (the text planner).
Nothing here imports MuJoCo.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from controller.commands.velocity import CommandLimits
    from controller.inputs.instructions import InstructionInbox
    from controller.reference.planned import PlannedReference
    from controller.reference.source import ReferenceSource
    from hw.types import RobotState
    from sim.perturbations import Perturbations


@dataclass(frozen=True)
class RunConfig:
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
    hardware: str | None = None  # a hardware config (name or path): the robot it names (None: the simulator directly)
    faults: str | None = None  # with simulated hardware: a fault plan (name or path) to inject
    picture: Path | None = None  # PNG of the final frame
    status: bool = False  # a live status line on stderr (mode, command, measured velocity, plan latency)
    perturbations: Perturbations | None = None  # pushes, friction, payload, motor strength, latency, noise (`sim.perturbations`)
    rt_priority: int = 0  # on a real robot: SCHED_FIFO priority of the run (0: normal scheduling), see hw.realtime
    cpu: int | None = None  # on a real robot: pin the run to this CPU
    estimator: bool = False  # estimate the base position on the simulator too (every other robot always runs the estimator)
    estimator_config: str | None = None  # the estimator's YAML (None: configs/estimator.yaml)
    record: Path | None = None  # an MCAP file that records every tick (`--record`, controller/recording)

    def __post_init__(self) -> None:
        if self.record is not None:  # refused here, before anything starts, when it cannot be written
            from controller.recording.sink import check_record_path  # noqa: PLC0415

            check_record_path(self.record)


@dataclass(frozen=True)
class RunHooks:
    """What a job built on a run adds (the text planner): its reference source over the planned one, a caption, an early end.

    `wrap_reference(planned, limits, truth)` returns the source the session ticks (closed with the
    run); `truth()` is the simulator's ground truth at the tick, also where the controller reads the
    simulator directly (None: no simulator behind the robot, a real one). `caption()` is written
    on each video frame and on the status line; `done()` ends the run before its duration.
    `instructions`: where the keyboard's text line sends what is typed (instructions given while
    the robot runs, `text/live.py`); `log()`: lines said since the last call, written to the
    flight recorder's log with `--record`. The driver takes the same hooks on every backend.
    """

    wrap_reference: Callable[[PlannedReference, CommandLimits, Callable[[], RobotState | None]], ReferenceSource]
    caption: Callable[[], str] | None = None
    done: Callable[[], bool] | None = None
    instructions: InstructionInbox | None = None
    log: Callable[[], list[str]] | None = None
