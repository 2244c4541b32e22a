"""Instructions from standard input: framed like the socket's, replies written by the reader's thread, the end closes the inbox."""

from __future__ import annotations

import io
import os

import pytest

from controller.inputs.instruction_stream import StreamInstructions
from controller.inputs.instructions import MAX_MESSAGE_BYTES, InstructionInbox
from hw.errors import ConfigError
from tests.conftest import wait_for


def test_lines_are_taken_bad_ones_said_and_the_end_closes_the_inbox() -> None:
    read, write = os.pipe()
    inbox, replies = InstructionInbox(), io.StringIO()
    with StreamInstructions(read, inbox, replies):
        os.write(write, b"walk forward 1 m\n\xff\n" + b"a" * (MAX_MESSAGE_BYTES + 1) + b"\n\nwave")
        os.close(write)  # the end of the stream: a last line without its newline counts
        assert wait_for(lambda: inbox.closed)
        assert [(i.text, i.origin, i.status) for i in inbox.log()] == [
            ("walk forward 1 m", "stdin", "queued"), ("", "stdin", "refused"), ("wave", "stdin", "queued")
        ]  # fmt: skip
        assert inbox.dropped == {"malformed": 1, "oversized": 1}
        walk = inbox.next_pending(1.0)
        assert walk is not None
        inbox.settle(walk, "running", "", "accepted: 1 clause: walk forward 1 m")  # a reply after the end is still written
        assert wait_for(lambda: "accepted: 1 clause" in replies.getvalue())
    lines = replies.getvalue().splitlines()
    assert lines[0].startswith("g1ctl run: dropped: not UTF-8 text") and "dropped: a line over 2048 bytes" in lines[1]
    assert lines[2].startswith("g1ctl run: refused: empty instruction") and lines[3] == "g1ctl run: accepted: 1 clause: walk forward 1 m"
    os.close(read)


def test_a_terminal_is_not_a_stream_of_instructions() -> None:
    master, slave = os.openpty()
    try:
        with pytest.raises(ConfigError, match="standard input is a terminal"):
            StreamInstructions(slave, InstructionInbox(), io.StringIO())
    finally:
        os.close(master)
        os.close(slave)
