"""Reading a recording back, whole or cut off: one pass over the file's records, in order.

A file that a run finished ends with a footer; one that a killed process left behind stops
somewhere in its last chunk. Both are read the same way, front to back (MCAP's streaming
reader), and a file cut off keeps every message before the cut: `problem` says where it stopped.
Only the topics asked for keep their messages; every topic is counted.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from controller.recording.sink import Topic
from hw.errors import ConfigError

MAGIC = b"\x89MCAP0\r\n"


@dataclass
class TopicStats:
    schema: str
    encoding: str
    count: int = 0
    first_ns: int | None = None
    last_ns: int | None = None


@dataclass
class Recording:
    """What a file holds: its topics and counts, the `run` metadata, the kept topics' messages (log time in ns, raw bytes)."""

    path: Path
    size: int
    complete: bool = False  # the footer was read: the run finished the file
    problem: str | None = None  # why reading stopped before the footer
    profile: str = ""
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    topics: dict[str, TopicStats] = field(default_factory=dict)
    kept: dict[str, list[tuple[int, bytes]]] = field(default_factory=dict)

    @property
    def messages(self) -> int:
        return sum(stats.count for stats in self.topics.values())

    @property
    def span_s(self) -> tuple[float, float] | None:
        """First and last log time over every topic, in seconds of the run's clock; None without messages."""
        firsts = [s.first_ns for s in self.topics.values() if s.first_ns is not None]
        lasts = [s.last_ns for s in self.topics.values() if s.last_ns is not None]
        return (min(firsts) / 1e9, max(lasts) / 1e9) if firsts else None

    @property
    def run(self) -> dict[str, str]:
        return self.metadata.get("run", {})

    def decoded(self, topic: Topic) -> list[tuple[float, Any]]:
        """A kept topic's messages: (time in s, the message: a protobuf message, or the JSON object)."""
        if topic.proto is not None:
            return [(ns / 1e9, topic.proto.FromString(data)) for ns, data in self._kept(topic.name)]
        return [(ns / 1e9, json.loads(data)) for ns, data in self._kept(topic.name)]

    def _kept(self, topic: str) -> list[tuple[int, bytes]]:
        if topic not in self.kept:
            raise KeyError(f"{topic} was not kept when {self.path} was read")
        return self.kept[topic]

    def warning(self) -> str | None:
        """One line for a file that was cut off, or None for a complete one."""
        if self.complete:
            return None
        return f"{self.path}: {self.problem}; read {self.messages} messages before it"


def read_recording(path: Path, keep: Collection[str] = ()) -> Recording:
    """Every record of `path` in order, keeping the messages of the topics in `keep`; ConfigError for a file that is no MCAP."""
    import zstandard  # noqa: PLC0415 - the recorder's dependencies load only when a recording is read
    from mcap.exceptions import McapError  # noqa: PLC0415
    from mcap.records import Channel, Footer, Header, Message, Metadata, Schema  # noqa: PLC0415
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    if not path.is_file():
        raise ConfigError(f"{path}: no such file (give a recording made with --record FILE.mcap)")
    recording = Recording(path, path.stat().st_size)
    with open(path, "rb") as stream:
        if stream.read(len(MAGIC)) != MAGIC:
            raise ConfigError(f"{path} is not an MCAP file (it does not begin with MCAP's magic bytes): give a file made with --record")
        stream.seek(0)
        schemas: dict[int, Schema] = {}
        channels: dict[int, TopicStats] = {}
        names: dict[int, str] = {}
        records: Iterator[Any] = StreamReader(stream).records
        try:
            for record in records:
                if isinstance(record, Message):
                    stats = channels.get(record.channel_id)
                    if stats is None:
                        continue  # a message before its channel: not something MCAP writers do
                    stats.count += 1
                    stats.first_ns = record.log_time if stats.first_ns is None else min(stats.first_ns, record.log_time)
                    stats.last_ns = record.log_time if stats.last_ns is None else max(stats.last_ns, record.log_time)
                    topic = names[record.channel_id]
                    if topic in keep:
                        recording.kept[topic].append((record.log_time, record.data))
                elif isinstance(record, Channel):
                    if record.id not in channels:
                        schema = schemas.get(record.schema_id)
                        stats = TopicStats(schema.name if schema is not None else "", record.message_encoding)
                        channels[record.id] = recording.topics.setdefault(record.topic, stats)
                        names[record.id] = record.topic
                        if record.topic in keep:
                            recording.kept.setdefault(record.topic, [])
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Metadata):
                    recording.metadata[record.name] = dict(record.metadata)
                elif isinstance(record, Header):
                    recording.profile = record.profile
                elif isinstance(record, Footer):
                    recording.complete = True
        except (McapError, struct.error, zstandard.ZstdError, ValueError, UnicodeDecodeError) as exc:
            recording.problem = _cut_off(exc, at_end=stream.tell() >= recording.size)
    for topic in keep:
        recording.kept.setdefault(topic, [])
    if not recording.complete and recording.problem is None:
        recording.problem = "the file ends before its footer"
    return recording


def _cut_off(exc: Exception, at_end: bool) -> str:
    """Why reading stopped: the file ran out (a recording its run could not finish), or a record that does not decode."""
    if at_end:
        return "the file ends before its footer: the recording was cut off (the run was killed before it could finish the file)"
    return f"the file is damaged after its last good record ({type(exc).__name__}: {exc})"
