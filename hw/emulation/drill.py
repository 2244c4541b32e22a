"""Judge a fault drill: did the stack do what the plan expects, on what reached the motors?

Pure: it reads the run's hardware report (`wire`: the audit of the decoded frames; the
safety layer's faults and clamped values) and whether the robot fell.
"""

from __future__ import annotations

from typing import Any

from hw.emulation.faults import FaultFile


def judge_drill(plan: FaultFile, source: str, hw: dict[str, Any], fell: bool, damp_reason: str = "") -> dict[str, Any]:
    """The drill's verdict: `passed`, and one line per way it failed. `damp_reason`: why the run damped, if it did
    (a fault at bring-up is named there, not among the latched faults of a robot that never came up)."""
    expect, start = plan.expect, plan.start_s
    wire = hw.get("wire") or {}
    reasons: list[str] = []
    verdict: dict[str, Any] = {"plan": source, "expected": expect.outcome, "fault_at_s": start, "within_s": expect.within_s}
    if not wire:
        reasons.append("no audit of the frames the motors decoded")
    elif wire["outside_limits"]:
        reasons.append(f"{wire['outside_limits']} commands outside the joint limits reached the motors")
    verdict["outside_limits"] = wire.get("outside_limits")
    faults = [str(f) for f in hw.get("fault_reasons") or []]
    if not faults and damp_reason.startswith("fault: "):
        faults = [damp_reason.removeprefix("fault: ")]
    until = wire.get("observed_until")
    if start is not None and until is not None and until < start:
        verdict |= {"faults": faults, "passed": False}
        return verdict | {"failures": [f"the run ended at {until:.2f} s, before the fault struck at {start:.2f} s: run it longer"]}
    if expect.outcome == "damping":
        safe_since = wire.get("safe_since")
        latency = None if safe_since is None or start is None else round(safe_since - start, 4)
        verdict["damping_latency_s"] = latency
        verdict["limp_joints"] = wire.get("limp_joints", [])
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
        if fell:
            reasons.append("the robot fell")
    elif not hw.get("clamped_values"):
        reasons.append("the safety layer clamped nothing")
    verdict["faults"] = faults
    verdict["passed"] = not reasons
    verdict["failures"] = reasons
    return verdict
