"""Instructions given while the robot runs (`g1ctl run`): each one planned, and switched to at once from where the robot is.

`LiveTextReference` is the reference source of a run that takes instructions. While none runs it
passes the input device's velocity and gesture to the planned reference, as a run without text
does. Instructions arrive in an `InstructionInbox` (the keyboard's text line, the local socket,
standard input); a `ResolverProcess` resolves them in a process of its own (the prompt's rules
and the sentence encoder, loaded and warmed up before the run starts) and embeds each clause's
text for the planner's text slot there too, so the control loop never waits for the encoder nor
shares its time with it. On the next tick the control thread decides each one:

- accepted: the `TextReference` switches to its program at once (`replace_program`): the clause
  running ends, marked interrupted, and the new first clause starts from the robot's pose now,
  its first plan asked for at once and blended in, as at a clause boundary;
- refused (the planner cannot do it, or the robot is not running: stopped, e-stopped, held): the
  robot goes on doing what it was doing, and the refusal's one line goes to the sender, the
  status line and the report.

"stop" wins over instructions: it reaches the control thread without waiting for the resolver,
ends what runs and cancels what arrived before it; the robot then stands until its input device
asks for something new (a key, a stick, the scenario's next step) or another instruction comes.
The supervisor wins over everything: once it stands or damps the robot (the stop button, an
e-stop, a lost estimate) the instruction running ends, and none is taken until it runs again.
After an instruction the robot also stands until the device asks for something new: a command
latched on the keyboard before the instruction does not resume on its own.

The latency measured for each instruction is the wall time from its arrival (Enter, its line on the
socket) to the first plan made for its first clause being in the reference buffer; for one that
came before the run started, from the run's start.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from controller.commands.velocity import ZERO, CommandLimits, VelocityCommand
from controller.inputs.instructions import Instruction, InstructionInbox
from controller.inputs.text_line import shown_line
from controller.reference.planned import PlannedReference
from controller.reference.source import ReferenceSource
from controller.reference.window import ReferenceWindow
from controller.reports import percentiles_ms
from controller.runtime.run_config import RunHooks
from controller.text.executor import ClauseRecord, TextReference, TextRunConfig
from controller.text.gesture_detector import detect_gestures
from controller.text.program import Program
from controller.text.resolver import Resolved, ResolverProcess
from hw.errors import ConfigError
from hw.types import FloatArray, RobotState

log = logging.getLogger(__name__)

SETTLE_S = 1.0  # once the instructions' channel has closed, the run ends this long after the last one is over
DEFAULT_RUN = TextRunConfig()
NOT_RUNNING = "the robot is not running (stopped, e-stopped or held): start it again, then send the instruction"


@dataclass
class _FirstPlan:
    """Waiting for the first plan of an instruction's first clause."""

    instruction: Instruction
    since: float  # the wall clock its latency counts from
    replans: int | None = None  # the scheduler's splices once that plan was asked for (None: not asked for yet)


class LiveTextReference(ReferenceSource):
    """The planned reference under the input device, switched to each accepted instruction as it comes."""

    needs_base_position = True  # plans are re-anchored on the measured root, instructions walk to positions

    def __init__(
        self, planned: PlannedReference, resolver: ResolverProcess, cfg: TextRunConfig = DEFAULT_RUN, limits: CommandLimits | None = None,
        truth: Callable[[], RobotState | None] | None = None, settle_s: float = SETTLE_S,
    ) -> None:  # fmt: skip
        """`resolver`: where the instructions of its inbox are resolved (it closes with the caller, not here)."""
        self.planned = planned
        self.inbox = resolver.inbox
        self.cfg = cfg
        self.limits = limits
        self.conditioned = resolver.conditioned
        self.truth = truth
        self.settle_s = settle_s
        self.resolver = resolver
        self._embeddings: dict[str, FloatArray] = {}  # the running program's clause texts, embedded by the resolver
        self.text: TextReference | None = None  # made at the first accepted instruction
        self.latencies_s: list[float] = []  # arrival to first plan, one per accepted instruction that got one
        self.resolve_seconds: list[float] = []
        self.now = 0.0  # run time of the latest tick
        self._running: Instruction | None = None
        self._first_plan: _FirstPlan | None = None
        self._baseline: tuple[VelocityCommand, str] | None = None  # the device's command when an instruction or a stop took over
        self._last_stop = -1  # sequence number of the latest stop
        self._decided = 0  # instructions taken from the resolver
        self._idle_since = 0.0  # run time since which nothing runs
        self._started = False
        self._t0 = 0.0  # the state's time at the run's start
        self._wall0 = time.perf_counter()  # the wall clock at the run's start

    @property
    def running(self) -> Instruction | None:
        return self._running

    # -- the session's side ----------------------------------------------------------------
    def start(self, state: RobotState) -> None:
        if not self._started:
            self._started, self._t0, self._wall0 = True, state.time, time.perf_counter()
        if self._running is not None and self.text is not None:
            self.text.start(state)  # a restart after a fall: the clause running goes on from where the robot is
        else:
            self.planned.start(state)

    def window(self, state: RobotState, velocity: VelocityCommand, gesture: str = "", hold: bool = False) -> ReferenceWindow:
        self.now = state.time - self._t0
        for stop in self.inbox.take_stops():
            self._stop(stop, state, velocity, gesture)
        if hold and self._running is not None:
            self._end_running(state, "interrupted", "the robot stopped running (the stop button, an e-stop or a hold)")
        for resolved in self.resolver.take():
            self._decide(resolved, state, velocity, gesture, hold)
        if self._running is None or self.text is None:
            velocity, gesture = self._device(velocity, gesture)
            return self.planned.window(state, velocity, gesture, hold)
        requests = self.planned.scheduler.counters.requests
        window = self.text.window(state, ZERO, "", hold)
        self._watch_first_plan(requests)
        if self.text.current is None:
            self._finish_running("done", self.text.records)
        return window

    def done(self) -> bool:
        """The instructions' channel closed (standard input ended), everything it sent is over, and the robot has stood
        `settle_s` since."""
        if not self.inbox.closed or self._running is not None or self._decided < self.inbox.forwarded:
            return False
        return self.now - self._idle_since >= self.settle_s - 1e-9

    @property
    def caption(self) -> str:
        """The status line's part: the text line being typed, else the clause running and the latest refusal."""
        typing = self.inbox.typing
        if typing is not None:
            return shown_line(typing)
        parts = []
        if self._running is not None and self.text is not None and self.text.current is not None:
            parts.append(self.text.caption)
        notice = self.inbox.notice()
        if notice and not (parts and notice.startswith("accepted")):
            parts.append(notice)
        return " | ".join(parts)

    def report(self) -> dict[str, Any]:
        if self._running is not None and self.text is not None:
            self._running.details["clauses_run"] = [self._clause_report(r) for r in self.text.records]
        block = self.inbox.report(self._wall0)
        block["first_plan_latency_s"] = latency_summary(self.latencies_s)
        block["resolve_ms"] = percentiles_ms(self.resolve_seconds)
        return self.planned.report() | {"instructions": block}

    def close(self) -> None:
        self.planned.close()

    # -- deciding --------------------------------------------------------------------------
    def _stop(self, stop: Instruction, state: RobotState, velocity: VelocityCommand, gesture: str) -> None:
        self._last_stop = stop.seq
        if self._running is not None:
            self._end_running(state, "stopped", f"stopped by instruction {stop.seq}")
        self._baseline = (velocity, gesture)
        self.inbox.settle(stop, "stop", "", "accepted: stop: the robot stands")

    def _decide(self, resolved: Resolved, state: RobotState, velocity: VelocityCommand, gesture: str, hold: bool) -> None:
        instruction = resolved.instruction
        self._decided += 1
        self.resolve_seconds.append(resolved.seconds)
        instruction.details |= {
            "resolve_ms": round(resolved.seconds * 1e3, 3),
            "embed_ms": round(resolved.embed_seconds * 1e3, 3),
            "queued_ms": round((time.perf_counter() - instruction.arrived) * 1e3, 3),  # arrival to this tick's decision
        }
        if instruction.seq < self._last_stop:
            self.inbox.settle(instruction, "cancelled", "a stop came after it", "cancelled: a stop came after it")
            return
        refusal = resolved.refusal if resolved.refusal is not None else NOT_RUNNING if hold else None
        program = resolved.program
        if refusal is None and program is not None:
            if self.text is None:
                embed = self._embedding if self.conditioned else None
                self.text = TextReference(program, self.planned, self.cfg, self.limits, embed, self.truth, detect_gestures)
            previous, self._embeddings = self._embeddings, resolved.embeddings
            try:
                replaced = self.text.replace_program(program, state)
            except ConfigError as exc:  # it walks to positions, and this robot's state has none
                self._embeddings, refusal = previous, str(exc)
            else:
                self._begin(instruction, program, replaced, velocity, gesture)
                return
        assert refusal is not None
        self.inbox.settle(instruction, "refused", refusal, f"refused: {refusal}")

    def _begin(
        self, instruction: Instruction, program: Program, replaced: list[ClauseRecord], velocity: VelocityCommand, gesture: str
    ) -> None:
        if self._running is not None:
            self._finish_running("interrupted", replaced, f"instruction {instruction.seq} came")
        else:
            self._baseline = (velocity, gesture)
        self._running = instruction
        self._first_plan = _FirstPlan(instruction, max(instruction.arrived, self._wall0))
        texts = [clause.text for clause in program.clauses]
        instruction.details |= {"started_s": round(self.now, 4), "clauses": texts}
        plural = "s" if len(texts) > 1 else ""
        self.inbox.settle(instruction, "running", "", f"accepted: {len(texts)} clause{plural}: {'; '.join(texts)}")

    def _end_running(self, state: RobotState, status: str, reason: str) -> None:
        assert self.text is not None
        self._finish_running(status, self.text.replace_program(None, state), reason)

    def _finish_running(self, status: str, records: list[ClauseRecord], reason: str = "") -> None:
        instruction = self._running
        assert instruction is not None
        instruction.status, instruction.reason = status, reason
        instruction.details |= {"ended_s": round(self.now, 4), "clauses_run": [self._clause_report(r) for r in records]}
        self._running = None
        self._idle_since = self.now
        if self._first_plan is not None and self._first_plan.instruction is instruction:
            self._first_plan = None

    def _embedding(self, text: str) -> FloatArray:
        """A clause's text conditioning, as the resolver embedded it."""
        return self._embeddings[text]

    def _device(self, velocity: VelocityCommand, gesture: str) -> tuple[VelocityCommand, str]:
        """The device's command, or standing while it still asks what it asked when an instruction or a stop took over."""
        if self._baseline is not None:
            if (velocity, gesture) == self._baseline:
                return ZERO, ""
            self._baseline = None
        return velocity, gesture

    def _watch_first_plan(self, requests_before: int) -> None:
        """The first plan asked for after the switch, once it is in the buffer, is the instruction's first planned frame."""
        watch = self._first_plan
        if watch is None:
            return
        counters = self.planned.scheduler.counters
        if watch.replans is None:
            if counters.requests > requests_before:
                watch.replans = counters.replans
            return
        if counters.replans > watch.replans:
            latency = time.perf_counter() - watch.since
            self.latencies_s.append(latency)
            watch.instruction.details["first_plan_latency_s"] = round(latency, 4)
            self._first_plan = None

    def _clause_report(self, record: ClauseRecord) -> dict[str, Any]:
        """One clause as it ran (times in run seconds; the text reference counts on the state's own clock)."""
        judged = record.judged
        displacement = judged.displacement
        return {
            "text": record.clause.text,
            "start_s": round(record.start_s - self._t0, 4),
            "end_s": None if record.end_s is None else round(record.end_s - self._t0, 4),
            "interrupted": record.interrupted,
            "timed_out": record.timed_out,
            "displacement": None if displacement is None else [round(displacement[0], 3), round(displacement[1], 3)],
            "heading_change_deg": round(math.degrees(judged.heading_change), 1),
        }


def latency_summary(seconds: list[float]) -> dict[str, float | int | None]:
    """p50, p95 and max in seconds, and how many."""
    if not seconds:
        return {"n": 0, "p50": None, "p95": None, "max": None}
    arr = np.asarray(seconds)
    return {
        "n": len(seconds),
        "p50": round(float(np.percentile(arr, 50)), 4),
        "p95": round(float(np.percentile(arr, 95)), 4),
        "max": round(float(arr.max()), 4),
    }


class LiveInstructions:
    """What a run adds to take instructions: the resolver's process (started, and its encoder loaded, here: before the run),
    the `hooks` (the live reference over the planned one, the caption, the end once a closed channel's instructions are
    over, the log lines), and that reference once the run has made it. Usable with `with`: `close` ends the resolver and
    cancels what was still waiting, telling each sender."""

    def __init__(self, inbox: InstructionInbox, condition_text: bool = False, cfg: TextRunConfig = DEFAULT_RUN) -> None:
        """`condition_text`: each clause's text conditions the planner, where the shipped planner was trained so."""
        self.inbox = inbox
        self.reference: LiveTextReference | None = None
        self.resolver = ResolverProcess(inbox, condition_text)
        self._cfg = cfg

    def __enter__(self) -> LiveInstructions:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _wrap(self, planned: PlannedReference, limits: CommandLimits, truth: Callable[[], RobotState | None]) -> LiveTextReference:
        self.reference = LiveTextReference(planned, self.resolver, self._cfg, limits, truth)
        return self.reference

    @property
    def hooks(self) -> RunHooks:
        return RunHooks(
            wrap_reference=self._wrap,
            caption=lambda: self.reference.caption if self.reference is not None else "",
            done=lambda: self.reference is not None and self.reference.done(),
            instructions=self.inbox,
            log=self.inbox.take_lines,
        )

    def close(self) -> None:
        self.resolver.close()
        waiting = self.inbox.drain_pending() + [resolved.instruction for resolved in self.resolver.take()]
        for instruction in waiting:
            self.inbox.settle(instruction, "cancelled", "the run ended", "cancelled: the run ended")
