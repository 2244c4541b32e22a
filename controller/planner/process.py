"""The planner in a process of its own, for a loop on the wall clock.

In one process a planner thread and the control loop share one interpreter lock: the plan's numpy
code and the tick's Python take turns, and a thread that wants the lock back waits up to the
interpreter's switch interval (5 ms) for the other to let go, or, on a busy machine, for the other
thread to be given a CPU at all. Measured on `walk_turn_stop` paced to the wall clock: the tracker's
step took 2.5-6.5 ms at p99 instead of 0.6, a plan 4.0-6.7 ms at the median (3.5 ms running free),
and its thread waited up to 2.7 ms to start one (docs/planner.md, "Latency on the wall clock").
Here the plan shares no lock with the loop. `submit` sends a request from the caller's thread (the
control tick: pickling a request takes tens of microseconds), so no thread has to be handed the lock
to start a plan; a reader thread, blocked on the pipe without the lock, takes the replies in. A reply that arrives
while the tick runs Python still waits for the lock, up to the switch interval: the run holds it at
`REPLY_SWITCH_INTERVAL_S` (1 ms, not 5) while this process plans for it. On `walk_turn_stop` paced to the wall clock
that took a reply's wait for the lock from 2.4 ms to 0.6 ms at p99 (docs/planner.md).

With `cpu`, the child runs on that CPU alone. Left to itself the kernel wakes a process next to the one that woke it:
the child onto the CPU where the tick that sent the request still runs, where it waits or migrates with cold caches.
Measured on a 2-CPU machine (walk_turn_stop on the wall clock): the foot lock's p99 1.3-1.5 ms pinned, 2.4-3.9 ms left
to the kernel, whose stalls of 2-3 ms hit any part of a plan (docs/planner.md). `planner_cpu` picks the CPU.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import multiprocessing
import os
import signal
import threading
from concurrent.futures import Future
from multiprocessing.connection import Connection
from pathlib import Path

from controller.planner.request import Plan, PlanRequest
from hw.errors import AssetError, G1Error

log = logging.getLogger(__name__)

START_TIMEOUT_S = 60.0  # loading onnxruntime and the model in a fresh interpreter: about a second here
STOP_TIMEOUT_S = 2.0
REPLY_SWITCH_INTERVAL_S = 0.001  # sys.setswitchinterval for a loop that takes replies: a reply waits at most this for the lock


class PlannerProcessError(G1Error, RuntimeError):
    """The planner process is gone, or answered with something that is not a plan."""


def planner_cpu(allowed: set[int], control_cpu: int | None) -> int | None:
    """The CPU for the planner process: the highest of `allowed` that is not the control loop's; None with fewer than two."""
    return max(allowed - {control_cpu}) if len(allowed) > 1 else None


class PlannerProcess:
    """`Planner.load(model_dir, threads)` run in a child process, warmed up (on `cpu` alone, when given); `submit` or
    `plan` ask it for plans.

    The child answers in the order asked, one plan at a time: a stalled plan holds the next ones up. Usable with `with`;
    `close` is safe twice.
    """

    def __init__(self, model_dir: Path | None = None, threads: int = 1, cpu: int | None = None) -> None:
        context = multiprocessing.get_context("spawn")  # no fork of a process that already runs threads
        self._conn, child = context.Pipe()
        args = (child, model_dir, threads, cpu)
        self._process = context.Process(target=_serve, args=args, name="g1ctl-planner", daemon=True)
        self._process.start()
        child.close()
        self._send_lock = threading.Lock()
        self._pending: collections.deque[Future[Plan]] = collections.deque()  # asked for, not answered yet, in order
        self._gone: str | None = None  # why the child no longer answers
        self._closed = False
        try:
            ready = self._conn.recv() if self._conn.poll(START_TIMEOUT_S) else None
        except (EOFError, OSError):
            ready = PlannerProcessError(f"the planner process ended before it was ready ({self._ended()})")
        if ready != "ready":
            self.close()
            if isinstance(ready, BaseException):
                raise ready
            raise PlannerProcessError(f"the planner process did not start within {START_TIMEOUT_S:g} s")
        self._reader = threading.Thread(target=self._read_replies, name="planner-replies", daemon=True)
        self._reader.start()

    def submit(self, request: PlanRequest) -> Future[Plan]:
        """Send `request` from this thread; the future gets the plan, or the error the child raised (PlanRequestError)."""
        future: Future[Plan] = Future()
        with self._send_lock:
            if self._closed or self._gone is not None:
                raise PlannerProcessError(f"the planner process is {'closed' if self._closed else f'gone ({self._gone})'}")
            self._pending.append(future)
            try:
                self._conn.send(request)
            except OSError as exc:
                self._pending.pop()
                raise PlannerProcessError(f"the planner process is gone ({self._ended()})") from exc
        return future

    def plan(self, request: PlanRequest) -> Plan:
        """One plan, waited for."""
        return self.submit(request).result()

    def _read_replies(self) -> None:
        while True:
            try:
                reply = self._conn.recv()
            except (EOFError, OSError):
                break
            future = self._pending.popleft()
            if isinstance(reply, BaseException):
                future.set_exception(reply)
            elif isinstance(reply, Plan):
                future.set_result(reply)
            else:
                future.set_exception(PlannerProcessError(f"the planner process answered {type(reply).__name__}, not a plan"))
        with self._send_lock:
            self._gone = "closed" if self._closed else self._ended()
            while self._pending:
                self._pending.popleft().set_exception(PlannerProcessError(f"the planner process is gone ({self._gone})"))

    def _ended(self) -> str:
        """How the child ended ("exit code 1", "killed by SIGKILL"), once it has."""
        self._process.join(timeout=1.0)
        code = self._process.exitcode
        if code is None:
            return "it closed its pipe but still runs"
        return f"killed by {signal.Signals(-code).name}" if code < 0 else f"exit code {code}"

    def close(self) -> None:
        """Ask the child to end (it ends by itself when this process dies), wait for it, stop taking replies."""
        with self._send_lock:
            if self._closed:
                return
            self._closed = True
            with contextlib.suppress(OSError):  # already gone
                self._conn.send(None)  # the child's sign to end; its end of the pipe closes, and the reader sees it
        self._process.join(timeout=STOP_TIMEOUT_S)
        if self._process.is_alive():
            log.warning("the planner process did not end; terminating it")
            self._process.terminate()
            self._process.join(timeout=STOP_TIMEOUT_S)
        reader = getattr(self, "_reader", None)
        if reader is not None:
            reader.join(timeout=STOP_TIMEOUT_S)
        self._conn.close()

    def __enter__(self) -> PlannerProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _serve(conn: Connection, model_dir: Path | None, threads: int, cpu: int | None) -> None:
    """The child: load and warm up the planner, then answer requests until asked to end or the parent is gone."""
    from controller.planner.runtime import Planner  # noqa: PLC0415 - onnxruntime in the child only

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle; it then ends the child
    try:
        if cpu is not None:
            os.sched_setaffinity(0, {cpu})
    except OSError as exc:  # a CPU this process may not use (a container's cpuset): say so, as a load error would
        conn.send(AssetError(f"the planner process cannot run on CPU {cpu}: {exc}"))
        return
    try:
        planner = Planner.load(model_dir, threads=threads)
        planner.warm_up()
    except G1Error as exc:
        conn.send(exc)
        return
    except Exception as exc:  # whatever stops the load is the parent's error to report
        conn.send(AssetError(f"the planner process could not load the planner: {exc}"))
        return
    conn.send("ready")
    while True:
        try:
            request = conn.recv()
        except (EOFError, OSError):
            return
        if request is None:
            return
        try:
            reply: object = planner.plan(request)
        except Exception as exc:  # sent back and raised in the caller, as a plan in the same process would
            reply = exc
        conn.send(reply)
