"""`g1ctl plan PROMPT --sim|--hardware NAME`: a resolved program executed on the G1, with its text report.

Build a run (`runtime/driver.py`, as `g1ctl sim` and `g1ctl run` do) with the planner in the loop,
put a `TextReference` over the planned reference through the run's `RunHooks`, end the run once
the last clause has ended and the robot has had a moment to come to rest, then add the text
report (clauses, totals, order, transitions) to the run's report. On the simulator, directly or
through simulated hardware (`hardware`), the run stands on the `stand` scenario and imports
MuJoCo (through the simulator's backend builders) when it starts; on a real G1 (no MuJoCo) the
robot's own remote is the input, so its E-stop stays in hand, and the current clause goes on the
status line. The composed plan on paper (`composed_transition_score`) imports neither.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from controller.commands.velocity import CommandLimits
from controller.reference.planned import PlannedReference
from controller.reports import write_report
from controller.text.executor import GESTURE_REDO_S, SETTLE_PER_WAYPOINT_S, TextReference, TextRunConfig, estimate_seconds
from controller.text.metrics import Embed
from controller.text.program import Program
from controller.text.report import Detect, text_report
from controller.tracking.presets import policy_rate_hz
from hw.types import RobotState

if TYPE_CHECKING:
    from controller.runtime.backend_registry import BackendChoice

SETTLE_S = 1.0  # the run goes on this long after the last clause
CORRECTION_S = GESTURE_REDO_S + SETTLE_PER_WAYPOINT_S  # a correction: a gesture held on, or a short re-approach and its settle
MAX_SECONDS = 180.0


@dataclass(frozen=True)
class TextSimConfig:
    policy: str = "fastsac"
    seed: int = 0
    video: Path | None = None
    report: Path | None = None
    progress: bool = False
    assets_dir: str | None = None
    # Through this hardware (simulated buses, the simulated G1 over DDS, a real G1), as `choose_backend` loaded it; None: the simulator
    hardware: BackendChoice | None = None
    status: bool = False  # a live status line on stderr, with the clause running
    record: Path | None = None  # an MCAP file that records every tick of the run
    run: TextRunConfig = field(default_factory=TextRunConfig)


def budget_seconds(program: Program, cfg: TextRunConfig) -> float:
    """Simulated time the run may take: every clause's timeout, plus the settling at the end."""
    seconds, here = SETTLE_S, (0.0, 0.0, 0.0)
    for clause in program.clauses:
        seconds += cfg.timeout_factor * estimate_seconds(clause, here, here) + cfg.timeout_margin_s
        seconds += cfg.max_corrections * (CORRECTION_S + cfg.timeout_margin_s)  # each correction a clause may need
    return min(seconds, MAX_SECONDS)


def run_text_sim(program: Program, cfg: TextSimConfig, embed: Embed, detect: Detect, text_embedding: Any = None) -> dict[str, Any]:
    """Execute `program` on the simulator, through `cfg.hardware`, or on a real G1; the report holds the run's figures and the
    text report.

    `text_embedding`: clause text -> the planner's text conditioning (None: the planner gets no text).
    """
    from controller.runtime.backend_registry import choose_backend  # noqa: PLC0415
    from controller.runtime.driver import execute  # noqa: PLC0415
    from controller.runtime.run_config import RunConfig, RunHooks  # noqa: PLC0415
    from controller.runtime.run_plan import resolve_run  # noqa: PLC0415

    holder: list[TextReference] = []

    def wrap(planned: PlannedReference, limits: CommandLimits, truth: Callable[[], RobotState | None]) -> TextReference:
        holder.append(TextReference(program, planned, cfg.run, limits, text_embedding, truth, detect))
        return holder[0]

    hooks = RunHooks(
        wrap_reference=wrap,
        caption=lambda: holder[0].caption if holder else "",
        done=lambda: bool(holder) and holder[0].finished_for(SETTLE_S),
    )
    choice = cfg.hardware or choose_backend(None)
    on_robot = not choice.entry.simulated
    run_cfg = RunConfig(
        scenario="stand", policy=cfg.policy, planner=True, duration=budget_seconds(program, cfg.run), seed=cfg.seed,
        input="unitree-remote" if on_robot else "scripted", video=cfg.video, report=None, plot=None, progress=cfg.progress,
        assets_dir=cfg.assets_dir, hardware=choice.hardware_name, status=cfg.status, record=cfg.record,
    )  # fmt: skip
    report = execute(resolve_run(run_cfg, choice), hooks)
    reference = holder[0]
    text = text_report(reference, policy_rate_hz(cfg.policy), embed, detect)  # one executed frame per tick of the policy
    out = {"prompt": program.prompt} | text | {"falls": report["falls"], "run": report}
    if cfg.report is not None:
        write_report(out, cfg.report)
    return out


def composed_frames(
    program: Program, plan: Any, blend_frames: int | None, seed: int = 0, text_embedding: Any = None, policy: str = TextSimConfig.policy,
    continue_motion: bool = True,
) -> tuple[Any, list[int]]:  # fmt: skip
    """`program` composed on paper (an ideal robot ticked at `policy`'s rate): the reference frames [T, 36] and the tick where
    each clause after the first begins. Blended joins, the crossfade baseline (`continue_motion` False), or naive ones
    (`blend_frames` None)."""
    from controller.text.kinematic import run_kinematic  # noqa: PLC0415
    from controller.text.report import reference_with_boundaries  # noqa: PLC0415

    cfg = replace(TextRunConfig(), blend_frames=blend_frames, continue_motion=continue_motion)
    reference = TextReference(program, PlannedReference(plan, seed=seed), cfg, embed=text_embedding)
    try:
        run_kinematic(reference, policy_rate_hz(policy), max_seconds=budget_seconds(program, reference.cfg))
    finally:
        reference.close()
    return reference_with_boundaries(reference)


def composed_transition_score(
    program: Program, plan: Any, blend_frames: int | None, seed: int = 0, text_embedding: Any = None, policy: str = TextSimConfig.policy,
    continue_motion: bool = True,
) -> float | None:  # fmt: skip
    """The transition score of `program` composed on paper (see `composed_frames`)."""
    from controller.text.metrics import transition_score  # noqa: PLC0415

    frames, boundaries = composed_frames(program, plan, blend_frames, seed, text_embedding, policy, continue_motion)
    return transition_score(frames, boundaries) if len(frames) else None
