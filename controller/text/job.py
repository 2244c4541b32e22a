"""`g1ctl plan PROMPT --sim`: a resolved program executed on the simulated G1, with its text report.

Build the `g1ctl sim` run on the `stand` scenario with the planner in the loop, put a
`TextReference` over the planned reference, end the run once the last clause has ended
and the robot has had a moment to come to rest, then add the text report (clauses,
totals, order, transitions) to the run's report. Imports MuJoCo (through `sim_run`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from controller.inputs.base import CommandLimits
from controller.reference.planned import PlannedReference
from controller.reports import write_report
from controller.runtime.sim_run import RunHooks, SimRunConfig
from controller.runtime.sim_run import run as run_sim
from controller.text.executor import TextReference, TextRunConfig, estimate_seconds
from controller.text.metrics import Embed
from controller.text.program import Program
from controller.text.report import Detect, text_report

SETTLE_S = 1.0  # the run goes on this long after the last clause
MAX_SECONDS = 180.0


@dataclass(frozen=True)
class TextSimConfig:
    policy: str = "fastsac"
    seed: int = 0
    video: Path | None = None
    report: Path | None = None
    progress: bool = False
    assets_dir: str | None = None
    run: TextRunConfig = field(default_factory=TextRunConfig)


def budget_seconds(program: Program, cfg: TextRunConfig) -> float:
    """Simulated time the run may take: every clause's timeout, plus the settling at the end."""
    seconds, here = SETTLE_S, (0.0, 0.0, 0.0)
    for clause in program.clauses:
        seconds += 2.0 * estimate_seconds(clause, here, here) + cfg.timeout_margin_s
    return min(seconds, MAX_SECONDS)


def run_text_sim(program: Program, cfg: TextSimConfig, embed: Embed, detect: Detect, text_embedding: Any = None) -> dict[str, Any]:
    """Execute `program` in simulation; the report holds the run's figures and the text report.

    `text_embedding`: clause text -> the planner's text conditioning (None: the planner gets no text).
    """
    holder: list[TextReference] = []

    def wrap(planned: PlannedReference, limits: CommandLimits) -> TextReference:
        holder.append(TextReference(program, planned, cfg.run, limits, text_embedding))
        return holder[0]

    hooks = RunHooks(
        wrap_reference=wrap,
        caption=lambda: holder[0].caption if holder else "",
        done=lambda: bool(holder) and holder[0].finished_for(SETTLE_S),
    )
    sim_cfg = SimRunConfig(
        scenario="stand", policy=cfg.policy, planner=True, duration=budget_seconds(program, cfg.run), seed=cfg.seed,
        video=cfg.video, report=None, plot=None, progress=cfg.progress, assets_dir=cfg.assets_dir,
    )  # fmt: skip
    report = run_sim(sim_cfg, hooks)
    reference = holder[0]
    text = text_report(reference, 50.0, embed, detect)
    out = {"prompt": program.prompt} | text | {"falls": report["falls"], "run": report}
    if cfg.report is not None:
        write_report(out, cfg.report)
    return out
