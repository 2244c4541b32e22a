"""Judge a fault drill: did the stack do what the plan expects, on what reached the motors?

Pure: it reads the run's hardware report (`wire`: the audit of the decoded frames; the
safety layer's faults and clamped values), whether the robot fell, and the run's whole report.
A drill's criteria are the functions of `CRITERIA`, each given the plan and the judged run and
returning its failure lines: a criterion on another block of the report (say, whether the
state estimator named a fault, for the IMU-bias drills) is one more function there, and one
more field of `DrillExpectation` when a plan states what it expects.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from hw.emulation.faults import FaultFile


@dataclass(frozen=True)
class JudgedRun:
    """What a drill is judged on; a criterion writes its figures into `verdict`."""

    hw: Mapping[str, Any]  # the backend's report: `wire`, `fault_reasons`, `clamped_values`
    wire: Mapping[str, Any]
    fell: bool
    faults: list[str]  # the latched faults (or the fault the bring-up failed on)
    report: Mapping[str, Any]  # the run's whole report
    verdict: dict[str, Any]


def judge_drill(
    plan: FaultFile, source: str, hw: dict[str, Any], fell: bool, damp_reason: str = "", report: Mapping[str, Any] | None = None
) -> dict[str, Any]:
    """The drill's verdict: `passed`, and one line per way it failed. `damp_reason`: why the run damped, if it did
    (a fault at bring-up is named there, not among the latched faults of a robot that never came up).
    `report`: the run's whole report, for criteria on its other blocks."""
    expect, start = plan.expect, plan.start_s
    wire = hw.get("wire") or {}
    verdict: dict[str, Any] = {"plan": source, "expected": expect.outcome, "fault_at_s": start, "within_s": expect.within_s}
    reasons = _wire_reasons(wire)
    verdict["outside_limits"] = wire.get("outside_limits")
    faults = [str(f) for f in hw.get("fault_reasons") or []]
    if not faults and damp_reason.startswith("fault: "):
        faults = [damp_reason.removeprefix("fault: ")]
    until = wire.get("observed_until")
    if start is not None and until is not None and until < start:
        verdict |= {"faults": faults, "passed": False}
        return verdict | {"failures": [f"the run ended at {until:.2f} s, before the fault struck at {start:.2f} s: run it longer"]}
    run = JudgedRun(hw, wire, fell, faults, report or {}, verdict)
    for criterion in CRITERIA:
        reasons += criterion(plan, run)
    verdict["faults"] = faults
    verdict["passed"] = not reasons
    verdict["failures"] = reasons
    return verdict


def _wire_reasons(wire: Mapping[str, Any]) -> list[str]:
    """No suite may waive this: a command outside the joint limits on the wire."""
    if not wire:
        return ["no audit of the frames the motors decoded"]
    if wire["outside_limits"]:
        return [f"{wire['outside_limits']} commands outside the joint limits reached the motors"]
    return []


def outcome_reasons(plan: FaultFile, run: JudgedRun) -> list[str]:
    """The plan's `expect.outcome`: every motor damped in time, a ride-through, or values clamped."""
    expect, start, wire, faults = plan.expect, plan.start_s, run.wire, run.faults
    reasons: list[str] = []
    if expect.outcome == "damping":
        safe_since = wire.get("safe_since")
        latency = None if safe_since is None or start is None else round(safe_since - start, 4)
        run.verdict["damping_latency_s"] = latency
        run.verdict["limp_joints"] = wire.get("limp_joints", [])
        if latency is None:
            reasons.append("not every motor ended damped or limp" if start is not None else "the plan has no fault to drill")
        elif latency < 0:
            reasons.append(f"every motor was already safe {-latency:.3f} s before the fault struck: the drill tested nothing")
        elif latency > expect.within_s:
            reasons.append(f"every motor safe {1e3 * latency:.0f} ms after the fault, more than the {1e3 * expect.within_s:.0f} ms stated")
        if expect.names and not any(expect.names in f for f in faults):
            reasons.append(f"no latched fault names '{expect.names}' (faults: {'; '.join(faults) or 'none'})")
    elif expect.outcome == "ride-through":
        if faults:
            reasons.append(f"a fault latched: {faults[0]}")
        if run.fell:
            reasons.append("the robot fell")
    elif not run.hw.get("clamped_values"):
        reasons.append("the safety layer clamped nothing")
    return reasons


Criterion = Callable[[FaultFile, JudgedRun], list[str]]
# Judged in this order after the wire check; add a criterion here (e.g. the estimator's fault line, read from `run.report`).
CRITERIA: tuple[Criterion, ...] = (outcome_reasons,)
