"""`g1ctl bench typed`: instructions sent through the local socket at random times while the simulated G1 runs.

A run like `g1ctl run --instructions PATH` on the wall clock (the simulator, or simulated hardware):
a script, a client thread of this process that talks like `g1ctl tell`, sends `instructions`
prompts through the run's socket at seeded random gaps (`min_gap_s` to `max_gap_s`), so that some
arrive while the one before still runs (they interrupt it) and some while the robot stands; `refused`
of them are ones the planner must refuse. Measured for each accepted one: the wall time from its
arrival (its line read off the socket) to the first plan made for its first clause being in the
reference buffer. The report: p50, p95 and max of that latency, falls, refusals (expected and not),
the run's overruns and real-time factor, and the machine's load average (other work on the machine
moves wall-clock figures). Target: p95 <= 0.3 s without a fall.
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from controller.inputs.instruction_socket import InstructionSocket, send_instruction
from controller.inputs.instructions import InstructionInbox
from controller.runtime.driver import execute
from controller.runtime.run_config import RunConfig
from controller.runtime.run_plan import resolve_run
from controller.text.live import LiveInstructions, latency_summary
from hw.errors import ConfigError, G1Error

TARGET_P95_S = 0.3
# Plain instructions: walks, turns, gestures, and two of two clauses.
ACCEPTED_POOL = (
    "walk forward 1 m", "turn left 90 degrees", "wave with your right hand", "walk backward half a meter",
    "sidestep left half a meter", "turn right 45 degrees", "raise both arms", "walk forward 2 meters, then turn left 90 degrees",
    "point forward", "put your hands on your hips", "walk forward 1 m and wave with your left hand", "cross your arms",
)  # fmt: skip
REFUSED_POOL = ("do a backflip", "fly to the kitchen", "dance like a chicken", "jump over the table")
START_S = 1.0  # run seconds before the first instruction: the robot stands on its own first
TAIL_S = 60.0  # the run's duration beyond the last send (it ends once the last instruction is over)


@dataclass(frozen=True)
class TypedBenchConfig:
    instructions: int = 20
    refused: int = 2  # how many of them are meant to be refused
    seed: int = 0
    min_gap_s: float = 0.5
    max_gap_s: float = 3.0
    policy: str = "fastsac"
    hardware: str | None = None  # simulated hardware (sim-can, ...); None: the simulator directly
    assets_dir: str | None = None

    def __post_init__(self) -> None:
        if self.instructions < 1 or not 0 <= self.refused <= self.instructions:
            raise ConfigError(f"--instructions must be at least 1 and --refused within [0, {self.instructions}], got {self.refused}")
        if not 0 < self.min_gap_s <= self.max_gap_s:
            raise ConfigError(f"--min-gap and --max-gap: 0 < min <= max, got {self.min_gap_s} and {self.max_gap_s}")


@dataclass(frozen=True)
class Send:
    at_s: float  # wall seconds after the run started ticking
    text: str
    refusal_expected: bool


def schedule(cfg: TypedBenchConfig) -> list[Send]:
    """The script: seeded texts (the refused ones at random places) at seeded random gaps."""
    rng = np.random.default_rng(cfg.seed)
    refused_at = set(rng.choice(cfg.instructions, size=cfg.refused, replace=False).tolist())
    sends, at = [], START_S
    for k in range(cfg.instructions):
        pool = REFUSED_POOL if k in refused_at else ACCEPTED_POOL
        sends.append(Send(round(at, 3), str(pool[int(rng.integers(len(pool)))]), k in refused_at))
        at += float(rng.uniform(cfg.min_gap_s, cfg.max_gap_s))
    return sends


class Sender(threading.Thread):
    """The script's client: sends each instruction at its time once the run ticks, keeps the replies, then closes the inbox
    (nothing more comes: the run ends once the last instruction is over)."""

    def __init__(self, path: Path, sends: list[Send], live: LiveInstructions) -> None:
        super().__init__(name="typed-bench-sender", daemon=True)
        self.path, self.sends, self.live = path, sends, live
        self.replies: list[str] = []
        self.error: str | None = None
        self.ended = threading.Event()  # the run ended (early): stop sending

    def run(self) -> None:
        try:
            while self.live.reference is None or self.live.reference.now <= 0.0:
                if self.ended.wait(0.01):
                    return
            start = time.perf_counter()
            for send in self.sends:
                if self.ended.wait(max(0.0, start + send.at_s - time.perf_counter())):
                    return
                self.replies.append(send_instruction(self.path, send.text))
        except G1Error as exc:
            self.error = str(exc)
        finally:
            self.live.inbox.close()


def run_typed_bench(cfg: TypedBenchConfig) -> dict[str, Any]:
    sends = schedule(cfg)
    load_before = os.getloadavg()
    inbox = InstructionInbox()
    run_cfg = RunConfig(
        scenario="stand", policy=cfg.policy, planner=True, duration=sends[-1].at_s + TAIL_S, seed=cfg.seed, input="scripted",
        realtime=True, assets_dir=cfg.assets_dir, hardware=cfg.hardware,
    )  # fmt: skip
    plan = resolve_run(run_cfg)
    with tempfile.TemporaryDirectory(prefix="g1ctl-typed-") as folder, LiveInstructions(inbox) as live:  # the encoder, before the run
        path = Path(folder) / "instructions.sock"
        with InstructionSocket(path, inbox) as server:
            sender = Sender(path, sends, live)
            sender.start()
            try:
                run = execute(plan, live.hooks)
            finally:
                sender.ended.set()
                sender.join(timeout=15.0)
            socket_counters = server.report()
    return _report(cfg, sends, sender, run, socket_counters, load_before)


def _report(
    cfg: TypedBenchConfig, sends: list[Send], sender: Sender, run: dict[str, Any], socket_counters: dict[str, Any],
    load_before: tuple[float, float, float],
) -> dict[str, Any]:  # fmt: skip
    block = run["instructions"]
    log = block["log"]
    expected = {s.text for s in sends if s.refusal_expected}
    refused = [entry["text"] for entry in log if entry["status"] == "refused"]
    latencies = [entry["first_plan_latency_s"] for entry in log if entry.get("first_plan_latency_s") is not None]
    summary = latency_summary(latencies)
    interrupting = sum(1 for entry in log if entry["status"] == "interrupted")
    p95 = summary["p95"]
    return {
        "seed": cfg.seed,
        "hardware": cfg.hardware,
        "instructions_sent": len(sender.replies),
        "instructions_planned": len(sends),
        "accepted": block["accepted"],
        "refused": len(refused),
        "refused_expected": sum(1 for s in sends if s.refusal_expected),
        "refused_unexpected": [text for text in refused if text not in expected],
        "interrupted_by_the_next": interrupting,
        "cancelled": block["cancelled"],
        "dropped_messages": block["dropped_messages"],
        "first_plan_latency_s": summary,
        "resolve_ms": block["resolve_ms"],
        "plan_latency_ms": run.get("plan_latency_ms"),
        "falls": run["falls"],
        "overruns": run["overruns"],
        "run_seconds": run["run_seconds"],
        "wall_seconds": run["wall_seconds"],
        "real_time_factor": run.get("real_time_factor"),
        "socket": socket_counters,
        "sender_error": sender.error,
        "machine": {"cpus": os.cpu_count(), "load_average_before": [round(v, 2) for v in load_before],
                    "load_average_after": [round(v, 2) for v in os.getloadavg()]},
        "target_p95_s": TARGET_P95_S,
        "targets_met": bool(p95 is not None and p95 <= TARGET_P95_S and run["falls"] == 0 and sender.error is None),
        "log": log,
    }  # fmt: skip
