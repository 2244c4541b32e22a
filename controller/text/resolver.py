"""Instructions resolved in a process of their own while the robot runs: the control loop never shares its time with the
sentence encoder.

`ResolverProcess` starts a child (`python -m controller.text.resolver`) that loads the text planner
(the prompt's rules and the sentence encoder), warms the encoder up and says it is ready, all before
the run starts. A thread here takes the inbox's instructions in arrival order, sends each to the child
and puts what comes back (the program with its clauses' text embeddings, or the refusal) where the
control thread `take`s it without waiting.

Why a process and not a thread: measured on a 2-core machine during a wall-clock run, the encoder on a
thread of the run's process took 250-720 ms to embed one clause (8-18 ms alone) and the loop overran
30-50 times in 18 s: numpy's OpenBLAS started a thread per core whose spinning fought the simulation,
and every small numpy call then waited for the interpreter lock. The child runs its numerical
libraries on one thread (`ONE_THREAD`) and holds no lock of the run's. It is a plain subprocess
talking over a socket pair, not `multiprocessing`'s spawn, which would import the caller's main
script again.

A resolution that takes over `timeout_s`, or a child that dies, refuses that instruction in one line
and starts a fresh child; the robot goes on as it was.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import Connection

from controller.inputs.instructions import Instruction, InstructionInbox
from controller.text.program import Program, PromptRefused
from hw.errors import G1Error
from hw.types import FloatArray

log = logging.getLogger(__name__)

ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
READY_TIMEOUT_S = 120.0  # a fresh process imports numpy and loads the encoder: seconds, far more on a loaded machine
RESOLVE_TIMEOUT_S = 10.0
POLL_S = 0.1
JOIN_TIMEOUT_S = 2.0
WARM_UP_TEXT = "stand still"  # the encoder's first embedding costs several times a later one

Resolve = Callable[[str], Program]
Embed = Callable[[str], FloatArray]  # clause text -> the planner's text conditioning


class ResolverError(G1Error, RuntimeError):
    """The resolver's process could not start."""


def load_text_planner(condition_text: bool = False) -> tuple[Resolve, Embed | None]:
    """The text planner's resolution, and its text conditioning (None: not asked for, or the shipped planner takes none)."""
    from controller.text.service import TextPlanner  # noqa: PLC0415 - loads the sentence encoder, in the child

    planner = TextPlanner.load(condition_text)
    return planner.resolve, planner.text_embedding()


@dataclass(frozen=True)
class Answer:
    """What the child says about one instruction."""

    seq: int
    program: Program | None
    refusal: str | None
    resolve_s: float
    embed_s: float = 0.0
    embeddings: dict[str, FloatArray] = field(default_factory=dict)


@dataclass(frozen=True)
class Resolved:
    """One instruction and its answer, for the control thread."""

    instruction: Instruction
    program: Program | None
    refusal: str | None  # why it cannot be planned (None: `program` is it)
    seconds: float  # wall time the resolution took, in the child
    embed_seconds: float = 0.0  # ... and the clauses' embeddings
    embeddings: dict[str, FloatArray] = field(default_factory=dict)  # clause text -> the planner's text conditioning


def serve(conn: Connection, condition_text: bool) -> None:
    """The child: load, warm up, say ready (and whether text conditions the planner), then answer until told to end."""
    try:
        resolve, embed = load_text_planner(condition_text)
        if embed is not None:
            embed(WARM_UP_TEXT)
    except Exception as exc:
        conn.send(("failed", f"{type(exc).__name__}: {exc}"))
        return
    conn.send(("ready", embed is not None))
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        seq, text = message
        start = time.perf_counter()
        try:
            program = resolve(text)
            resolved = time.perf_counter()
            embeddings = {clause.text: embed(clause.text) for clause in program.clauses} if embed is not None else {}
            answer = Answer(seq, program, None, resolved - start, time.perf_counter() - resolved, embeddings)
        except PromptRefused as exc:
            answer = Answer(seq, None, str(exc), time.perf_counter() - start)
        except Exception as exc:  # a resolver bug refuses this instruction, loudly
            answer = Answer(seq, None, f"the resolver failed on it ({type(exc).__name__}: {exc})", time.perf_counter() - start)
        conn.send(answer)


class ResolverProcess:
    """Resolves `inbox`'s instructions in a child process; `take` the results; usable with `with`, `close` safe twice."""

    def __init__(
        self, inbox: InstructionInbox, condition_text: bool = False, timeout_s: float = RESOLVE_TIMEOUT_S,
        ready_timeout_s: float = READY_TIMEOUT_S,
    ) -> None:  # fmt: skip
        """`condition_text`: each clause's text conditions the planner, where the shipped planner was trained so."""
        self.inbox = inbox
        self.timeout_s = timeout_s
        self.ready_timeout_s = ready_timeout_s
        self.restarts = 0  # children started afresh after one died or stalled
        self.conditioned = False  # the child embeds clause texts for the planner
        self._condition_text = condition_text
        self._process: subprocess.Popen[bytes] | None = None
        self._conn: Connection | None = None
        self._results: queue.SimpleQueue[Resolved] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._closed = False
        self._start_child()
        self._thread = threading.Thread(target=self._forward, name="instruction-resolver", daemon=True)
        self._thread.start()

    def __enter__(self) -> ResolverProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def pid(self) -> int | None:
        return self._process.pid if self._process is not None else None

    def _start_child(self) -> None:
        ours, theirs = socket.socketpair()
        command = [sys.executable, "-m", "controller.text.resolver", str(theirs.fileno())]
        if self._condition_text:
            command.append("--text")
        try:
            process = subprocess.Popen(
                command, pass_fds=(theirs.fileno(),), env=os.environ | ONE_THREAD, stdin=subprocess.DEVNULL,
                start_new_session=True,  # Ctrl-C in the terminal is the run's to handle; the run ends the child
            )  # fmt: skip
        except OSError as exc:
            ours.close()
            raise ResolverError(f"the instruction resolver's process did not start: {exc}") from exc
        finally:
            theirs.close()
        conn = Connection(ours.detach())
        self._process, self._conn = process, conn
        try:
            message = conn.recv() if conn.poll(self.ready_timeout_s) else None
        except (EOFError, OSError):
            message = ("failed", f"it ended (exit code {process.poll()})")
        if message is None or message[0] != "ready":
            self._end_child()
            why = message[1] if message is not None else f"no answer within {self.ready_timeout_s:g} s"
            raise ResolverError(f"the instruction resolver's process did not start: {why}")
        self.conditioned = bool(message[1])

    def _end_child(self) -> None:
        process, conn = self._process, self._conn
        if conn is not None:
            with contextlib.suppress(OSError, ValueError):
                conn.send(None)
            conn.close()
        if process is not None:
            try:
                process.wait(timeout=JOIN_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(timeout=JOIN_TIMEOUT_S)
        self._process = self._conn = None

    def _forward(self) -> None:
        while not self._stop.is_set():
            instruction = self.inbox.next_pending(POLL_S)
            if instruction is not None:
                self._results.put(self._ask(instruction))

    def _ask(self, instruction: Instruction) -> Resolved:
        """The child's answer for `instruction`; a child that is gone, or too slow, refuses it and is replaced."""
        start = time.perf_counter()
        try:
            if self._conn is None:
                self._start_child()
            assert self._conn is not None
            self._conn.send((instruction.seq, instruction.text))
            while not self._conn.poll(POLL_S):
                if self._stop.is_set():
                    return Resolved(instruction, None, "the run ended before it was planned", time.perf_counter() - start)
                if time.perf_counter() - start > self.timeout_s:
                    raise TimeoutError(f"planning it took over {self.timeout_s:g} s")
            answer: Answer = self._conn.recv()
        except (EOFError, OSError, TimeoutError, ResolverError) as exc:
            if isinstance(exc, TimeoutError | ResolverError):
                reason = str(exc)
            else:
                reason = f"the resolver's process ended ({exc or 'its connection closed'})"
            return self._failed(instruction, reason, start)
        except Exception as exc:  # an answer that cannot be read: this instruction is refused, loudly, on a fresh child
            log.error("instruction %d: the resolver's answer failed", instruction.seq, exc_info=exc)
            return self._failed(instruction, f"the resolver failed on it ({type(exc).__name__}: {exc})", start)
        return Resolved(instruction, answer.program, answer.refusal, answer.resolve_s, answer.embed_s, answer.embeddings)

    def _failed(self, instruction: Instruction, reason: str, start: float) -> Resolved:
        log.error("instruction %d: %s; the resolver starts afresh", instruction.seq, reason)
        self._end_child()
        self.restarts += 1
        return Resolved(instruction, None, reason, time.perf_counter() - start)

    def take(self) -> list[Resolved]:
        """The results ready now, in order; never waits."""
        out = []
        while True:
            try:
                out.append(self._results.get_nowait())
            except queue.Empty:
                return out

    def close(self) -> None:
        """Stop forwarding and end the child."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        self._thread.join(timeout=JOIN_TIMEOUT_S + POLL_S)
        if self._thread.is_alive():
            log.warning("the instruction resolver's thread did not stop within %.1f s", JOIN_TIMEOUT_S)
        else:
            self._end_child()


def main(argv: list[str]) -> None:
    """The child: `python -m controller.text.resolver FD [--text]`, answering on the socket FD."""
    conn = Connection(int(argv[0]))
    try:
        serve(conn, condition_text="--text" in argv[1:])
    finally:
        conn.close()


if __name__ == "__main__":  # run as `-m`: this file is __main__; what it sends must pickle as controller.text.resolver's
    from controller.text.resolver import main as child_main

    child_main(sys.argv[1:])
