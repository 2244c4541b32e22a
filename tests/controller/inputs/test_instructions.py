"""Instructions at the door: what is no instruction is refused or dropped saying why, stops go first, messages are framed."""

from __future__ import annotations

import pytest

from controller.inputs.instructions import (
    MAX_INSTRUCTION_CHARS,
    BadInstruction,
    InstructionInbox,
    LineFramer,
    decode_instruction,
    is_stop,
)


@pytest.mark.parametrize(
    ("raw", "kind", "says"),
    [
        (b"walk \xff forward", "malformed", "not UTF-8 text (byte 5)"),
        ("walk\x1b[A forward", "malformed", "control character 0x1b at 4"),
        ("wave \ufffd", "malformed", "not UTF-8 text"),
        ("   ", "empty", "empty instruction"),
        (b"", "empty", "empty instruction"),
        ("a" * (MAX_INSTRUCTION_CHARS + 1), "too_long", f"instruction of 501 characters: at most {MAX_INSTRUCTION_CHARS}"),
    ],
)
def test_what_is_no_instruction_says_why(raw: bytes | str, kind: str, says: str) -> None:
    with pytest.raises(BadInstruction, match=says.replace("(", r"\(").replace(")", r"\)")) as caught:
        decode_instruction(raw)
    assert caught.value.kind == kind


def test_an_instruction_is_utf8_text_stripped() -> None:
    assert decode_instruction("  wave\twith your right hand \r") == "wave\twith your right hand"
    assert decode_instruction("gehe 1 m vorwärts".encode()) == "gehe 1 m vorwärts"
    assert decode_instruction("a" * MAX_INSTRUCTION_CHARS) == "a" * MAX_INSTRUCTION_CHARS


def test_stop_is_the_word_alone() -> None:
    assert all(is_stop(text) for text in ("stop", "Stop!", "STOP.", "halt", "stop !"))
    assert not any(is_stop(text) for text in ("stop walking", "walk to the stop sign", "nonstop"))


def test_the_framer_splits_lines_and_drops_oversized_ones_once() -> None:
    framer = LineFramer(max_bytes=8)
    assert framer.feed(b"wave\r\nwalk") == [b"wave"]
    assert framer.feed(b" 1m\n") == [b"walk 1m"]
    assert framer.feed(b"0123456789") == [LineFramer.OVERSIZED]
    assert framer.feed(b"more of it") == []  # skipped up to its newline
    assert framer.feed(b"!\nok\n") == [b"ok"]
    assert framer.feed(b"\n") == [b""]
    assert framer.feed(b"last") == [] and framer.finish() == b"last" and framer.finish() is None


def test_the_inbox_refuses_at_the_door_queues_and_passes_stops_first() -> None:
    inbox = InstructionInbox()
    replies: list[str] = []
    refused = inbox.submit(b"", "socket", replies.append)
    assert refused is not None and refused.status == "refused" and replies == [f"refused: {refused.reason}"]
    assert inbox.submit(b"\xfe\xff", "socket", replies.append) is None  # malformed: dropped and counted, not logged
    assert replies[-1].startswith("dropped: not UTF-8 text") and inbox.dropped["malformed"] == 1
    inbox.drop("oversized", "a message over 2048 bytes without a newline", replies.append)
    walk = inbox.submit("walk forward 1 m", "socket", replies.append)
    stop = inbox.submit("Stop!", "keyboard")
    assert walk is not None and stop is not None and stop.status == "stop"
    assert inbox.take_stops() == [stop] and inbox.take_stops() == []
    assert inbox.next_pending(0.1) is walk and inbox.next_pending(0.01) is None
    assert inbox.forwarded == 1 and len(replies) == 3  # the walk is replied to once it is decided
    assert inbox.notice().startswith("dropped: a message over 2048 bytes")
    assert inbox.notice(max_age_s=-1.0) == ""  # an old notice leaves the status line
    assert len(inbox.take_lines()) == 3 and inbox.take_lines() == []
    report = inbox.report(wall0=0.0)
    assert report["received"] == 3 and report["refused"] == 1 and report["stops"] == 1
    assert report["dropped_messages"] == {"oversized": 1, "malformed": 1}
    assert [entry["status"] for entry in report["log"]] == ["refused", "queued", "stop"]
