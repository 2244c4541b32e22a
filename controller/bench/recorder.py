"""`g1ctl bench recorder`: what the flight recorder costs the control loop, and whether it keeps up.

The same run (walk_turn_stop, as fast as the machine goes) with recording off and on, alternating,
in this process. The overhead is counted in CPU time, which other processes on the machine do not
inflate: the loop's thread's extra time per tick, plus all of the writer thread's, counted as if the
loop waited for it (they share one interpreter lock), as a share of the control period. The wall
time per tick of each (the best of the rounds, and the medians' difference) is reported beside it:
it also catches waiting for the lock, and on a shared machine it moves with everything else. As fast as
it goes is the harder case for the recorder: its writer thread must keep up with several times
real time, and it shares the interpreter with the loop. Also: what `record` costs inside the tick,
the messages, bytes and drops of each recorded run (targets: at most 5 % of the cycle, no drops).
"""

from __future__ import annotations

import dataclasses
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from controller.runtime.driver import run
from controller.runtime.run_config import RunConfig
from controller.tracking.presets import policy_rate_hz

TARGET_SHARE = 0.05  # of the control period
SCENARIO = "walk_turn_stop"


def _one(cfg: RunConfig, rate_hz: float) -> dict[str, Any]:
    """One run: wall time per tick, and CPU time per tick of this (the loop's) thread and of all the others (the writer's)."""
    loop_cpu, all_cpu = time.thread_time(), time.process_time()
    report = run(cfg)
    loop_cpu, all_cpu = time.thread_time() - loop_cpu, time.process_time() - all_cpu
    if report["falls"]:
        raise RuntimeError("the robot fell during the benchmark: its figures would not compare")
    ticks = round(report["run_seconds"] * rate_hz)
    per_tick = {"wall": report["wall_seconds"], "loop_cpu": loop_cpu, "other_cpu": all_cpu - loop_cpu}
    return {f"{key}_per_tick_ms": 1e3 * value / ticks for key, value in per_tick.items()} | (
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
        run(RunConfig(scenario=SCENARIO, policy=policy, duration=1.0, hardware=hardware, assets_dir=assets_dir))  # warm-up: not counted
        for i in range(max(rounds, 1)):
            base = RunConfig(scenario=SCENARIO, policy=policy, duration=duration, hardware=hardware, assets_dir=assets_dir, seed=i)
            off.append(_one(base, rate_hz))
            on.append(_one(dataclasses.replace(base, record=folder / f"round{i}.mcap"), rate_hz))
    median = {key: {side: statistics.median(r[f"{key}_per_tick_ms"] for r in runs) for side, runs in (("off", off), ("on", on))}
              for key in ("wall", "loop_cpu", "other_cpu")}  # fmt: skip
    best_wall = {side: min(r["wall_per_tick_ms"] for r in runs) for side, runs in (("off", off), ("on", on))}
    # The cost to a tick: the loop's own extra CPU time, and all of the writer's counted as if the loop waited for it
    # (one interpreter lock: on a machine with a core to spare, that is the most it can wait)
    extra_ms = sum(median[key]["on"] - median[key]["off"] for key in ("loop_cpu", "other_cpu"))
    share = extra_ms / period_ms
    recorders = [r["recorder"] for r in on]
    drops = max(r["drops"] for r in recorders)
    return {
        "benchmark": "recorder",
        "scenario": SCENARIO,
        "policy": policy,
        "hardware": hardware,
        "run_seconds": duration,
        "rounds": len(on),
        "control_period_ms": round(period_ms, 3),
        "overhead_ms": round(extra_ms, 4),
        "overhead_share": round(share, 4),
        # medians of the rounds, per tick: this (the loop's) thread, and the others (the writer's, and the backend's own)
        "loop_cpu_per_tick_ms": {side: round(value, 4) for side, value in median["loop_cpu"].items()},
        "other_cpu_per_tick_ms": {side: round(value, 4) for side, value in median["other_cpu"].items()},
        # wall time per tick: what a loaded machine inflates, and what catches waiting for the interpreter lock
        "wall_per_tick_ms": {side: round(value, 4) for side, value in best_wall.items()},
        "wall_overhead_share": round((best_wall["on"] - best_wall["off"]) / period_ms, 4),
        "wall_overhead_share_median": round((median["wall"]["on"] - median["wall"]["off"]) / period_ms, 4),
        "record_ms": {"p50": max(r["record_ms"]["p50"] for r in recorders), "p99": max(r["record_ms"]["p99"] for r in recorders)},
        "drops": drops,
        "messages": max(r["messages"] for r in recorders),
        "megabytes_per_minute": round(max(r["bytes"] for r in recorders) / 1e6 * 60.0 / duration, 2),
        "targets": {"overhead_share": TARGET_SHARE, "drops": 0},
        "targets_met": share <= TARGET_SHARE and drops == 0,
        "off_runs_wall_ms": [round(r["wall_per_tick_ms"], 4) for r in off],
        "on_runs_wall_ms": [round(r["wall_per_tick_ms"], 4) for r in on],
    }
