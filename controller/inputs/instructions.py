"""Instructions sent while the robot runs: checked at the door, queued for planning, and each one's fate kept.

Every channel (the keyboard's text line, the local socket, standard input) hands what it read to
one `InstructionInbox`, from its own thread. The inbox checks it (UTF-8 text, no control characters,
not empty, at most `MAX_INSTRUCTION_CHARS`), says why when it is not (one reply line to the sender,
the status line's notice, the run's log and report), passes "stop" straight to the control thread
(it must not wait behind an instruction being planned) and queues the rest for the resolver
(`controller/text/live.py`). A message a channel could not frame (over `MAX_MESSAGE_BYTES` without a
newline) or decode is dropped and counted. Nothing here plans or moves: no planner, no encoder.
"""

from __future__ import annotations

import collections
import queue
import threading
import time
import unicodedata
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from hw.errors import G1Error

MAX_INSTRUCTION_CHARS = 500
# One message on the socket or standard input, newline included: 500 characters of 4-byte UTF-8 fit, with room to spare.
MAX_MESSAGE_BYTES = 2048
STOP_WORDS = frozenset({"stop", "halt"})  # an instruction that is only one of these, whatever the case and final punctuation
NOTICE_S = 6.0  # wall seconds a refusal stays on the status line
PREVIEW_CHARS = 120  # a refused instruction's text in the report, at most

Reply = Callable[[str], None]  # where one reply line goes (the socket client that sent it); must not block


class BadInstruction(G1Error, ValueError):
    """A message that is not an instruction: `kind` is "malformed" (not UTF-8 text), "empty" or "too_long"."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


def decode_instruction(raw: bytes | str) -> str:
    """The instruction `raw` holds, stripped of surrounding white space; `BadInstruction` saying what is wrong."""
    if isinstance(raw, bytes):
        try:
            raw = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise BadInstruction("malformed", f"not UTF-8 text (byte {exc.start}): send instructions as UTF-8, one a line") from exc
    if "\ufffd" in raw:  # what a terminal's stray bytes decode to
        raise BadInstruction("malformed", "not UTF-8 text: send instructions as UTF-8, one a line")
    text = raw.strip()
    control = next((i for i, c in enumerate(text) if c != "\t" and unicodedata.category(c) == "Cc"), None)
    if control is not None:
        code = ord(text[control])
        raise BadInstruction("malformed", f"control character 0x{code:02x} at {control}: send plain text, one instruction a line")
    if not text:
        raise BadInstruction("empty", "empty instruction: say what the robot should do, e.g. 'walk forward 1 m'")
    if len(text) > MAX_INSTRUCTION_CHARS:
        raise BadInstruction("too_long", f"instruction of {len(text)} characters: at most {MAX_INSTRUCTION_CHARS}")
    return text


def is_stop(text: str) -> bool:
    """The instruction only says stop ("stop", "Stop!", "halt.")."""
    return text.lower().rstrip(" .!").strip() in STOP_WORDS


class LineFramer:
    """Splits a byte stream into newline-ended messages (a trailing CR dropped); one longer than `max_bytes` is cut off,
    reported once as `OVERSIZED` and skipped up to its newline."""

    OVERSIZED = None

    def __init__(self, max_bytes: int = MAX_MESSAGE_BYTES) -> None:
        self.max_bytes = max_bytes
        self._buffer = bytearray()
        self._skipping = False

    def feed(self, data: bytes) -> list[bytes | None]:
        """The messages `data` completes, in order; None for each one dropped as oversized."""
        out: list[bytes | None] = []
        start = 0
        while True:
            end = data.find(b"\n", start)
            if not self._skipping:
                self._buffer += data[start:] if end < 0 else data[start:end]
                if len(self._buffer) > self.max_bytes:
                    self._buffer.clear()
                    self._skipping = True
                    out.append(self.OVERSIZED)
            if end < 0:
                return out
            if not self._skipping:
                out.append(bytes(self._buffer).removesuffix(b"\r"))
            self._buffer.clear()
            self._skipping = False
            start = end + 1

    def finish(self) -> bytes | None:
        """What is left once the stream ended: a last message without its newline (None: nothing)."""
        rest, skipping = bytes(self._buffer), self._skipping
        self._buffer.clear()
        self._skipping = False
        return rest.removesuffix(b"\r") if rest and not skipping else None


@dataclass(eq=False)
class Instruction:
    """One message and its fate. `status`: queued, then refused, cancelled or running, then done, interrupted or
    stopped; "stop" for a stop. `arrived`: the wall clock (`time.perf_counter`) when it came in (Enter, its newline)."""

    seq: int
    origin: str  # keyboard, socket, stdin
    text: str
    arrived: float
    reply: Reply | None = field(default=None, repr=False)
    status: str = "queued"
    reason: str = ""
    details: dict[str, Any] = field(default_factory=dict)  # what the run adds: resolution time, clauses, first plan

    def as_report(self, wall0: float) -> dict[str, Any]:
        text = self.text if len(self.text) <= PREVIEW_CHARS else self.text[:PREVIEW_CHARS] + "..."
        out = {"seq": self.seq, "origin": self.origin, "text": text, "arrived_s": round(self.arrived - wall0, 4), "status": self.status}
        return out | ({"reason": self.reason} if self.reason else {}) | self.details


class InstructionInbox:
    """Where every channel's instructions arrive (any thread), the resolver takes them, the control thread decides."""

    def __init__(self, clock: Callable[[], float] = time.perf_counter) -> None:
        self.clock = clock
        self.typing: str | None = None  # the keyboard's text line while it is open (the status line shows it)
        self.dropped: collections.Counter[str] = collections.Counter()  # messages dropped: oversized, malformed
        self._lock = threading.Lock()
        self._log: list[Instruction] = []  # every instruction, in arrival order
        self._pending: queue.SimpleQueue[Instruction] = queue.SimpleQueue()
        self._stops: collections.deque[Instruction] = collections.deque()
        self._lines: list[str] = []  # said since `take_lines`
        self._notice: tuple[float, str] | None = None
        self._closed = False
        self.forwarded = 0  # instructions queued for the resolver (the control thread decides each one)

    # -- the channels' side (any thread) ---------------------------------------------------
    def submit(self, raw: bytes | str, origin: str, reply: Reply | None = None, arrived: float | None = None) -> Instruction | None:
        """Take one message: refused at once (said why) when it is no instruction, a stop for the control thread, or
        queued for planning. None when it was dropped as malformed."""
        arrived = self.clock() if arrived is None else arrived
        try:
            text = decode_instruction(raw)
        except BadInstruction as exc:
            if exc.kind == "malformed":
                self.drop("malformed", str(exc), reply)
                return None
            shown = raw if isinstance(raw, str) else raw.decode("utf-8", errors="replace")
            instruction = self._logged(origin, shown.strip(), arrived, reply)
            self.settle(instruction, "refused", str(exc), f"refused: {exc}")
            return instruction
        instruction = self._logged(origin, text, arrived, reply)
        if is_stop(text):
            instruction.status = "stop"
            with self._lock:
                self._stops.append(instruction)
        else:
            with self._lock:
                self.forwarded += 1
            self._pending.put(instruction)
        return instruction

    def drop(self, kind: str, reason: str, reply: Reply | None = None) -> None:
        """A message dropped before it was an instruction (`kind`: oversized, malformed): counted, and said."""
        with self._lock:
            self.dropped[kind] += 1
        self.say(f"dropped: {reason}", reply)

    def close(self) -> None:
        """The channel sends nothing more (standard input ended): the run may end once everything sent is over."""
        self._closed = True

    @property
    def closed(self) -> bool:
        return self._closed

    def _logged(self, origin: str, text: str, arrived: float, reply: Reply | None) -> Instruction:
        with self._lock:
            instruction = Instruction(len(self._log), origin, text, arrived, reply)
            self._log.append(instruction)
        return instruction

    # -- the resolver's side ---------------------------------------------------------------
    def next_pending(self, timeout: float) -> Instruction | None:
        """The next instruction to plan, waiting at most `timeout` s (None: none came)."""
        try:
            return self._pending.get(timeout=timeout)
        except queue.Empty:
            return None

    # -- the control thread's side ---------------------------------------------------------
    def take_stops(self) -> list[Instruction]:
        with self._lock:
            stops = list(self._stops)
            self._stops.clear()
        return stops

    def settle(self, instruction: Instruction, status: str, reason: str, line: str) -> None:
        """`instruction` is decided (`status`, why): its one reply line goes to its sender, the status line and the log."""
        instruction.status, instruction.reason = status, reason
        self.say(line, instruction.reply)

    def say(self, line: str, reply: Reply | None = None) -> None:
        """One line for the sender (`reply`), the status line's notice and the run's log."""
        with self._lock:
            self._lines.append(line)
            self._notice = (self.clock(), line)
        if reply is not None:
            reply(line)

    def notice(self, max_age_s: float = NOTICE_S) -> str:
        """The latest line said, while it is younger than `max_age_s` wall seconds ("" otherwise)."""
        notice = self._notice
        return notice[1] if notice is not None and self.clock() - notice[0] <= max_age_s else ""

    def take_lines(self) -> list[str]:
        """The lines said since the last call (for the flight recorder's log)."""
        with self._lock:
            lines, self._lines = self._lines, []
        return lines

    def drain_pending(self) -> list[Instruction]:
        """Instructions still waiting for the resolver (the run is ending)."""
        out = []
        while True:
            try:
                out.append(self._pending.get_nowait())
            except queue.Empty:
                return out

    def log(self) -> list[Instruction]:
        with self._lock:
            return list(self._log)

    def report(self, wall0: float) -> dict[str, Any]:
        """Counts by fate, the dropped messages, and every instruction with its times (`wall0`: the run's start, wall clock)."""
        log = self.log()
        statuses = collections.Counter(i.status for i in log)
        accepted = sum(statuses[s] for s in ("running", "done", "interrupted", "stopped"))
        return {
            "received": len(log),
            "accepted": accepted,
            "refused": statuses["refused"],
            "cancelled": statuses["cancelled"],
            "stops": statuses["stop"],
            "dropped_messages": {"oversized": self.dropped["oversized"], "malformed": self.dropped["malformed"]},
            "log": [i.as_report(wall0) for i in log],
        }
