"""The figures of a robustness report: survival with a confidence interval, per condition and over push impulse."""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any

Z95 = 1.959964  # two-sided 95 %


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion: sensible at 0 and n, unlike the normal approximation."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def summarize(results: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per condition (`group`): episodes, falls, faults, survival and its 95 % interval, mean velocity error, failed episodes;
    with simulated hardware, commands outside the limits on the wire; for drills, how many passed and the slowest damping."""
    groups: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in results:
        groups[r["group"]].append(r)
    summary = {}
    for group, rs in sorted(groups.items()):
        done = [r for r in rs if r["status"] == "done"]
        survived = sum(r["falls"] == 0 and not r.get("ended_in_fault", False) for r in done)  # a robot damped by a fault is down too
        low, high = wilson_interval(survived, len(done))
        errors = [r["velocity_error_mean"] for r in done if r["velocity_error_mean"] == r["velocity_error_mean"]]
        summary[group] = {
            "condition": rs[0]["condition"],
            "episodes": len(done),
            "failed_episodes": len(rs) - len(done),
            "falls": sum(r["falls"] for r in done),
            "faults": sum(bool(r.get("ended_in_fault")) for r in done),
            "survival": round(survived / len(done), 4) if done else None,
            "survival_ci95": [round(low, 4), round(high, 4)],
            "velocity_error_mean": round(sum(errors) / len(errors), 4) if errors else None,
            "push_impulse_ns": rs[0].get("push_impulse_ns", 0.0),
            "pushes_only": all(r.get("pushes_only", False) for r in done),
        }
        walls = [r["outside_limits"] for r in done if r.get("outside_limits") is not None]
        if walls:  # simulated hardware: commands outside the joint limits, decoded on the wire
            summary[group]["outside_limits"] = sum(walls)
        drills = [r["drill"] for r in done if r.get("drill")]
        if drills:
            latencies = [d["damping_latency_s"] for d in drills if d.get("damping_latency_s") is not None]
            summary[group] |= {
                "drills": len(drills),
                "drills_passed": sum(d["passed"] for d in drills),
                "damping_latency_max_s": max(latencies) if latencies else None,
                "within_s": drills[0]["within_s"] if drills[0]["expected"] == "damping" else None,
                "drill_failures": [
                    f"seed {r['seed']}: {'; '.join(r['drill']['failures'])}" for r in done if r.get("drill") and not r["drill"]["passed"]
                ],
            }
    return summary


def largest_impulse_survived(curve: list[tuple[float, float]], level: float = 0.9) -> float | None:
    """The largest push impulse (N s) whose survival is at least `level`, every smaller one included; None if none."""
    best = None
    for impulse, survival in sorted(curve):
        if survival < level:
            break
        best = impulse
    return best


def push_curves(conditions: dict[str, dict[str, Any]], level: float = 0.9) -> dict[str, dict[str, Any]]:
    """Per setup (scenario, policy, planner, hardware: the condition's group without its label), survival over
    push impulse from the conditions that only push (the nominal one at 0 N s), and the largest impulse survived at `level`."""
    curves: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for group, figures in conditions.items():
        if figures["survival"] is None or not figures.get("pushes_only"):
            continue  # only the nominal and the pushed conditions lie on the curve
        setup = group.rsplit("/", 1)[0]
        curves[setup].append((float(figures["push_impulse_ns"]), float(figures["survival"])))
    return {
        setup: {
            "impulse_ns": [i for i, _ in sorted(points)],
            "survival": [s for _, s in sorted(points)],
            f"impulse_survived_at_{round(100 * level)}_ns": largest_impulse_survived(points, level),
        }
        for setup, points in sorted(curves.items())
        if any(impulse > 0 for impulse, _ in points)
    }


def disagreements(first: dict[str, dict[str, Any]], second: dict[str, dict[str, Any]]) -> list[str]:
    """Conditions where two runs (other seeds) disagree: neither run's survival lies within the other's 95 % interval.

    Symmetric on purpose: a Wilson interval of a condition that saw one fall never reaches 1.00, so a re-run
    that saw none would "leave" it however rare the falls are; each run must be out of the other's reach.
    """
    lines = []
    for group in sorted(set(first) & set(second)):
        a, b = first[group], second[group]
        if a["survival"] is None or b["survival"] is None:
            continue
        b_in_a = a["survival_ci95"][0] <= b["survival"] <= a["survival_ci95"][1]
        a_in_b = b["survival_ci95"][0] <= a["survival"] <= b["survival_ci95"][1]
        if not (b_in_a or a_in_b):
            lines.append(f"{group}: survival {a['survival']:.2f} {a['survival_ci95']} against {b['survival']:.2f} {b['survival_ci95']}")
    return lines
