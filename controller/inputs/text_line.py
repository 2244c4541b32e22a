"""The keyboard's text line: an instruction typed on the status line, edited key by key.

`edit_line` is pure, like `keyboard.apply_key`, which sends it the keys while the line is open.
Enter sends the line (an empty one too: the inbox refuses it and says why), Backspace deletes a
character and, on an empty line, closes it, Ctrl-U clears it, Ctrl-W deletes the last word. Other
control keys do nothing here; Esc never reaches it (the keyboard's e-stop wins while typing too).
"""

from __future__ import annotations

import unicodedata

OPEN_KEYS = ("/", "t")  # open the text line (outside it)
SEND_KEYS = ("\r", "\n")
BACKSPACE_KEYS = ("\x7f", "\x08")
CLEAR_KEY = "\x15"  # Ctrl-U
WORD_KEY = "\x17"  # Ctrl-W
SHOWN_CHARS = 60  # the status line shows the end of a longer line


def edit_line(line: str, key: str) -> tuple[str | None, str | None]:
    """(the line after `key`, None once closed; the text sent, None unless `key` sent it)."""
    if key in SEND_KEYS:
        return None, line
    if key in BACKSPACE_KEYS:
        return (line[:-1], None) if line else (None, None)
    if key == CLEAR_KEY:
        return "", None
    if key == WORD_KEY:
        kept = line.rstrip()
        return kept[: len(kept) - len(kept.split(" ")[-1])], None
    if key == "\t":
        return line + " ", None
    if len(key) != 1 or unicodedata.category(key) == "Cc":
        return line, None
    return line + key, None


def shown_line(line: str) -> str:
    """The open line as the status line shows it: a prompt, its last `SHOWN_CHARS` characters, a cursor."""
    tail = line if len(line) <= SHOWN_CHARS else "..." + line[-SHOWN_CHARS:]
    return f"instruction> {tail}_"
