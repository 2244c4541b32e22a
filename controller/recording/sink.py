"""The MCAP writer of the flight recorder: a thread behind a bounded queue, so the control loop never waits on a disk.

The loop `offer`s one item per tick and goes on: a full queue drops the item and counts it.
The thread turns items into messages (`encode`, given by the recorder), writes them in
zstd-compressed chunks and ends a chunk at least once a second, so a run that dies hard (a
killed process, a power cut) leaves every chunk but the last second's readable by a streaming
reader. `close` drains the queue and writes the summary and footer: every exit path of a run
calls it (the run's `ExitStack`), so an ended run, a fault, an exception and Ctrl-C all leave a
complete file. A write that fails (the disk is full) stops the recording, not the run: the
error is kept for the report and later items count as dropped.
"""

from __future__ import annotations

import json
import logging
import queue
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from hw.errors import ConfigError

log = logging.getLogger(__name__)

QUEUE_ITEMS = 500  # ticks: 10 s at 50 Hz before the loop would have to drop
CHUNK_BYTES = 1 << 20  # a chunk ends at this size (uncompressed) ...
CHUNK_SECONDS = 1.0  # ... or this long after the last one, whichever comes first
BATCH_SECONDS = 0.1  # once caught up, the writer waits this long for more: a wake-up every few ticks, not every one
CLOSE_TIMEOUT_S = 30.0  # for the thread to drain the queue and finish the file
PROFILE = "g1ctl"


@dataclass(frozen=True)
class Topic:
    """A channel: JSON with a JSON schema, or protobuf with Foxglove's message class."""

    name: str
    schema_name: str
    json_schema: dict[str, Any] | None = None  # a JSON channel's schema
    proto: Any = None  # a protobuf channel's message class

    def __post_init__(self) -> None:
        if (self.json_schema is None) == (self.proto is None):
            raise ValueError(f"topic {self.name}: give a JSON schema or a protobuf class, one of them")


# What `encode` yields: the topic, the log time (ns on the run's clock) and the encoded message.
Message = tuple[Topic, int, bytes]


def check_record_path(path: Path) -> None:
    """Refuse, before anything starts, a recording that could not be written: the suffix, a folder in the way, no write access.

    The file is opened for appending and closed (and removed again when it was not there): the system says
    whether it can be written, whoever runs this. The folders to it are made, as for a report."""
    if path.suffix.lower() != ".mcap":
        raise ConfigError(f"--record {path}: a recording is an MCAP file, name it *.mcap")
    if path.is_dir():
        raise ConfigError(f"--record {path}: that is a folder; give a file name ending in .mcap")
    existed = path.exists()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "ab"):
            pass
    except OSError as exc:
        raise ConfigError(f"--record {path}: cannot write it ({exc.strerror or exc}); choose a writable path") from exc
    if not existed:
        path.unlink()


class McapSink:
    """The writer thread. `offer` never blocks; `close` finishes the file and is safe twice."""

    def __init__(
        self, path: Path, encode: Callable[[Any], Iterable[Message]], metadata: dict[str, str], queue_items: int = QUEUE_ITEMS,
        chunk_seconds: float = CHUNK_SECONDS, batch_seconds: float = BATCH_SECONDS,
    ) -> None:  # fmt: skip
        """`encode` turns an offered item into messages, on the writer thread."""
        from mcap.writer import CompressionType, Writer  # noqa: PLC0415 - the recorder's dependencies load only when recording

        self.path = path
        self._encode = encode
        if path.suffix.lower() != ".mcap":
            raise ConfigError(f"--record {path}: a recording is an MCAP file, name it *.mcap")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._file: IO[bytes] = open(path, "wb")  # noqa: SIM115 - closed by close()
        except OSError as exc:
            raise ConfigError(f"--record {path}: cannot write it ({exc.strerror or exc}); choose a writable path") from exc
        self._writer = Writer(self._file, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="g1ctl flight recorder")
        self._writer.add_metadata("run", metadata)
        self._channels: dict[str, int] = {}
        self._queue: queue.Queue[Any] = queue.Queue(maxsize=queue_items)
        self._chunk_seconds = chunk_seconds
        self._batch_seconds = batch_seconds
        self.offered = 0  # items the loop offered
        self._refused = 0  # of those, not queued: the queue was full, or the writer had stopped (counted by the loop)
        self._lost = 0  # queued, then lost: the one being written when a write failed, and those after it (by the writer)
        self.messages = 0  # messages written
        self.error: str | None = None  # why the writer stopped early
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="flight-recorder", daemon=True)
        self._thread.start()

    def offer(self, item: Any) -> bool:
        """Queue `item` for writing; False (and counted) when the queue is full or the writer has stopped."""
        self.offered += 1
        if self.error is None and not self._closed:
            try:
                self._queue.put_nowait(item)
                return True
            except queue.Full:
                pass
        self._refused += 1
        return False

    def _run(self) -> None:
        last_chunk = time.monotonic()
        try:
            while True:
                item = self._queue.get()
                if item is _STOP:
                    break
                for topic, log_time, data in self._encode(item):
                    self._writer.add_message(self._channel(topic), log_time, data, publish_time=log_time)
                    self.messages += 1
                if self._queue.empty():
                    time.sleep(self._batch_seconds)  # caught up: the next wake-up finds several ticks (fewer switches with the loop)
                if time.monotonic() - last_chunk >= self._chunk_seconds:
                    self._writer.flush()  # ends the chunk: on disk, readable, should the process die now
                    last_chunk = time.monotonic()
        except Exception as exc:  # the recording stops, the run goes on; the report says why
            self.error = f"{type(exc).__name__}: {exc}"
            self._lost += 1  # the item being written
            log.error("flight recorder stopped writing %s: %s", self.path, self.error)
            self._drain()
        try:
            self._writer.add_metadata("recorder", {"offered": str(self.offered), "drops": str(self.drops)} | _error(self.error))
            self._writer.finish()
            self._file.flush()
        except Exception as exc:
            self.error = self.error or f"{type(exc).__name__}: {exc}"
            log.error("flight recorder could not finish %s: %s", self.path, self.error)

    def _drain(self) -> None:
        """After a failed write: count what is still queued as dropped, up to the stop."""
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            self._lost += 1

    def _channel(self, topic: Topic) -> int:
        channel = self._channels.get(topic.name)
        if channel is None:
            if topic.proto is not None:
                from mcap_protobuf.schema import register_schema  # noqa: PLC0415

                schema = register_schema(self._writer, topic.proto)
                encoding = "protobuf"
            else:
                data = json.dumps(topic.json_schema).encode()
                schema = self._writer.register_schema(name=topic.schema_name, encoding="jsonschema", data=data)
                encoding = "json"
            channel = self._channels[topic.name] = self._writer.register_channel(topic.name, encoding, schema)
        return channel

    def close(self) -> None:
        """Drain the queue, write the summary and the footer, close the file; safe twice."""
        if self._closed:
            return
        self._closed = True
        try:
            self._queue.put(_STOP, timeout=CLOSE_TIMEOUT_S)
        except queue.Full:
            log.error("flight recorder: the writer did not take the stop in %s s; %s is left unfinished", CLOSE_TIMEOUT_S, self.path)
        self._thread.join(CLOSE_TIMEOUT_S)
        if self._thread.is_alive():
            self.error = self.error or f"the writer did not finish in {CLOSE_TIMEOUT_S} s"
            return  # the thread still owns the file
        self._file.close()

    @property
    def drops(self) -> int:
        """Items offered and not written: refused by a full queue, or lost to a failed write."""
        return self._refused + self._lost

    @property
    def bytes(self) -> int:
        return self.path.stat().st_size if self.path.exists() else 0

    def report(self) -> dict[str, Any]:
        return {"path": str(self.path), "messages": self.messages, "drops": self.drops, "bytes": self.bytes} | _error(self.error)


_STOP = object()


def _error(error: str | None) -> dict[str, str]:
    return {"error": error} if error is not None else {}
