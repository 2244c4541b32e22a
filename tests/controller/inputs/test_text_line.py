"""The keyboard's text line: editing as a pure function, the keys around it, and the reader handing instructions on."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from controller.commands.velocity import CommandLimits
from controller.inputs.instructions import InstructionInbox
from controller.inputs.keyboard import KeyboardSource, KeyboardState, apply_key
from controller.inputs.text_line import SHOWN_CHARS, edit_line, shown_line
from tests.conftest import Terminal, wait_for

LIMITS = CommandLimits(vx=(-0.5, 0.5))


def typed(keys: str, state: KeyboardState | None = None, text: bool = True) -> KeyboardState:
    state = state or KeyboardState()
    for key in keys:
        state = apply_key(state, key, LIMITS, text=text)
    return state


def test_editing_keys() -> None:
    assert edit_line("wal", "k") == ("walk", None)
    assert edit_line("walk", "\x7f") == ("wal", None)  # Backspace (DEL)
    assert edit_line("walk", "\x08") == ("wal", None)  # Backspace (^H)
    assert edit_line("", "\x7f") == (None, None)  # Backspace on an empty line closes it
    assert edit_line("walk forward", "\x15") == ("", None)  # Ctrl-U clears
    assert edit_line("walk forward ", "\x17") == ("walk ", None)  # Ctrl-W deletes the last word
    assert edit_line("walk", "\x17") == ("", None)
    assert edit_line("walk", "\t") == ("walk ", None)
    assert edit_line("walk", "\x01") == ("walk", None)  # other control keys do nothing
    assert edit_line("walk", "é") == ("walké", None)
    assert edit_line("walk forward 1 m", "\r") == (None, "walk forward 1 m")  # Enter sends and closes
    assert edit_line("", "\n") == (None, "")  # an empty line is sent too: the inbox refuses it, saying why


def test_the_status_line_shows_the_end_of_a_long_line() -> None:
    assert shown_line("wave") == "instruction> wave_"
    long = "a" * (SHOWN_CHARS + 10)
    assert shown_line(long) == f"instruction> ...{'a' * SHOWN_CHARS}_"


def test_slash_or_t_opens_the_line_and_keys_type_into_it() -> None:
    state = typed("w/walk")
    assert state.line == "walk" and state.velocity.vx == pytest.approx(0.1)  # the command in force stays
    assert typed("t").line == ""
    state = typed("\r", state)
    assert state.sent == "walk" and state.line is None and not state.buttons.start  # Enter sends, it does not start
    assert typed("/", text=False).line is None  # without an inbox to send to, / is no key


def test_letters_are_text_while_typing_and_esc_still_e_stops() -> None:
    state = typed("/kick xq ")
    assert state.line == "kick xq " and not state.buttons.estop and not state.buttons.stop
    assert state.velocity.is_zero()  # q, x, w... type, they do not drive
    stopped = typed("\x1b", state)
    assert stopped.buttons.estop and stopped.line is None and stopped.velocity.is_zero()
    assert typed("k").buttons.estop  # outside the line K is the e-stop, as before


@pytest.fixture
def terminal() -> Iterator[Terminal]:
    term = Terminal()
    yield term
    term.close()


def test_the_reader_shows_the_line_and_sends_what_enter_sends_to_the_inbox(terminal: Terminal) -> None:
    inbox = InstructionInbox()
    with KeyboardSource(LIMITS, stream=terminal, instructions=inbox) as source:
        terminal.type("/walk forward 1 mé")
        assert wait_for(lambda: inbox.typing == "walk forward 1 mé")  # two bytes, one character
        terminal.type("\x7f\r")
        assert wait_for(lambda: len(inbox.log()) == 1)
        (instruction,) = inbox.log()
        assert instruction.text == "walk forward 1 m" and instruction.origin == "keyboard" and instruction.status == "queued"
        assert inbox.next_pending(1.0) is instruction
        assert inbox.typing is None  # closed once sent
        terminal.type("/stop\r")
        assert wait_for(lambda: len(inbox.log()) == 2)
        assert [s.text for s in inbox.take_stops()] == ["stop"]
        terminal.type("/wave\x1b")  # Esc while typing: the e-stop, and nothing is sent
        assert wait_for(lambda: source.poll(0.0).buttons.estop)
        assert inbox.typing is None and len(inbox.log()) == 2
