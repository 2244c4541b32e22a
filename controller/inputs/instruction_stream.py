"""Instructions read from a stream that is not a terminal: `echo "walk forward 1 m" | g1ctl run --instructions -`.

One message a line, framed and checked like the socket's (`instructions.LineFramer`, the inbox).
A thread of its own reads the stream (waiting at most `READ_POLL_S` at a time, so `close` never
hangs on a pipe left open) and writes the reply lines to `replies` (stderr): a slow reader of
those blocks this thread, never the control loop. The end of the stream closes the inbox: the
run may end once everything sent is over.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue
import select
import threading
from types import TracebackType
from typing import Self, TextIO

from controller.inputs.instructions import InstructionInbox, LineFramer
from hw.errors import ConfigError

log = logging.getLogger(__name__)

READ_POLL_S = 0.05
READ_BYTES = 4096
JOIN_TIMEOUT_S = 1.0


class StreamInstructions:
    """Reads instructions from file descriptor `fd` into `inbox`; usable with `with`, `close` safe twice."""

    def __init__(self, fd: int, inbox: InstructionInbox, replies: TextIO, prefix: str = "g1ctl run: ") -> None:
        if os.isatty(fd):
            raise ConfigError("--instructions -: standard input is a terminal; pipe instructions in, or type them after the keyboard's /")
        self.fd = fd
        self.inbox = inbox
        self._replies = replies
        self._prefix = prefix
        self._lines: queue.SimpleQueue[str] = queue.SimpleQueue()
        self._framer = LineFramer()
        self._stop = threading.Event()
        self._closed = False
        self._thread = threading.Thread(target=self._read, name="instruction-stream", daemon=True)
        self._thread.start()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    def _reply(self, line: str) -> None:
        self._lines.put(line)

    def _read(self) -> None:
        try:
            while not self._stop.is_set():
                self._write_replies()
                ready, _, _ = select.select([self.fd], [], [], READ_POLL_S)
                if not ready:
                    continue
                data = os.read(self.fd, READ_BYTES)
                if not data:
                    last = self._framer.finish()
                    if last is not None:
                        self.inbox.submit(last, "stdin", self._reply)
                    break
                for message in self._framer.feed(data):
                    if message is LineFramer.OVERSIZED:
                        self.inbox.drop("oversized", f"a line over {self._framer.max_bytes} bytes", self._reply)
                    else:
                        self.inbox.submit(message, "stdin", self._reply)
        except OSError as exc:  # said, and the stream counts as ended
            log.error("reading instructions from standard input failed: %s", exc)
        self.inbox.close()
        while not self._stop.wait(READ_POLL_S):  # the replies of what was sent go on being written
            self._write_replies()
        self._write_replies()

    def _write_replies(self) -> None:
        while True:
            try:
                line = self._lines.get_nowait()
            except queue.Empty:
                return
            with contextlib.suppress(OSError, ValueError):  # stderr closed: the replies are in the report too
                self._replies.write(f"{self._prefix}{line}\n")
                self._replies.flush()

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        self._thread.join(timeout=JOIN_TIMEOUT_S)
        if self._thread.is_alive():
            log.warning("the instruction reader did not stop within %.1f s", JOIN_TIMEOUT_S)
