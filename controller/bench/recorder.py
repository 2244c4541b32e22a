"""`g1ctl bench recorder`: what the flight recorder costs the control loop, and whether it keeps up.

The same run (walk_turn_stop, as fast as the machine goes) with recording off and on, alternating,
in this process: the wall time per tick of each, the best of the rounds (the one least disturbed by
whatever else runs on the machine), and the difference as a share of the control period. As fast as
it goes is the harder case for the recorder: its writer thread must keep up with several times
real time, and it shares the interpreter with the loop. Also: what `record` costs inside the tick,
the messages, bytes and drops of each recorded run (targets: at most 5 % of the cycle, no drops).
"""

from __future__ import annotations

import dataclasses
import statistics
import tempfile
from pathlib import Path
from typing import Any

from controller.runtime.sim_run import SimRunConfig, run
from controller.tracking.presets import policy_rate_hz

TARGET_SHARE = 0.05  # of the control period
SCENARIO = "walk_turn_stop"


def _one(cfg: SimRunConfig, rate_hz: float) -> dict[str, Any]:
    report = run(cfg)
    if report["falls"]:
        raise RuntimeError("the robot fell during the benchmark: its figures would not compare")
    ticks = round(report["sim_seconds"] * rate_hz)
    return {"wall_per_tick_ms": 1e3 * report["wall_seconds"] / ticks, "ticks": ticks} | (
        {"recorder": report["recorder"]} if "recorder" in report else {}
    )


def run_recorder_bench(
    duration: float = 60.0, rounds: int = 2, hardware: str | None = None, policy: str = "fastsac", assets_dir: str | None = None,
    keep: Path | None = None,
) -> dict[str, Any]:  # fmt: skip
    """`keep`: a folder for the recordings (default: a temporary one, removed)."""
    rate_hz = policy_rate_hz(policy)
    period_ms = 1e3 / rate_hz
    off: list[dict[str, Any]] = []
    on: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="bench-recorder-") as tmp:
        folder = keep or Path(tmp)
        for i in range(max(rounds, 1)):
            base = SimRunConfig(scenario=SCENARIO, policy=policy, duration=duration, hardware=hardware, assets_dir=assets_dir, seed=i)
            off.append(_one(base, rate_hz))
            on.append(_one(dataclasses.replace(base, record=folder / f"round{i}.mcap"), rate_hz))
    best_off = min(r["wall_per_tick_ms"] for r in off)
    best_on = min(r["wall_per_tick_ms"] for r in on)
    median_off = statistics.median(r["wall_per_tick_ms"] for r in off)
    median_on = statistics.median(r["wall_per_tick_ms"] for r in on)
    share = (best_on - best_off) / period_ms
    recorders = [r["recorder"] for r in on]
    record_p50 = max(r["record_ms"]["p50"] for r in recorders)
    record_p99 = max(r["record_ms"]["p99"] for r in recorders)
    drops = max(r["drops"] for r in recorders)
    return {
        "benchmark": "recorder",
        "scenario": SCENARIO,
        "policy": policy,
        "hardware": hardware,
        "sim_seconds": duration,
        "rounds": len(on),
        "control_period_ms": round(period_ms, 3),
        "wall_per_tick_ms": {"off": round(best_off, 4), "on": round(best_on, 4)},
        "overhead_share": round(share, 4),  # extra wall time per tick with recording on, over the control period
        "overhead_share_median": round((median_on - median_off) / period_ms, 4),
        "record_ms": {"p50": record_p50, "p99": record_p99},  # what `record` costs inside the tick, worst run
        "record_share_p99": round(record_p99 / period_ms, 4),
        "drops": drops,
        "messages": max(r["messages"] for r in recorders),
        "megabytes_per_minute": round(max(r["bytes"] for r in recorders) / 1e6 * 60.0 / duration, 2),
        "targets": {"overhead_share": TARGET_SHARE, "drops": 0},
        "targets_met": share <= TARGET_SHARE and drops == 0,
        "off_runs_ms": [round(r["wall_per_tick_ms"], 4) for r in off],
        "on_runs_ms": [round(r["wall_per_tick_ms"], 4) for r in on],
    }
