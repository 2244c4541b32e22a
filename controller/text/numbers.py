"""Word numbers to digits, so quantities are read by one set of patterns.

`words_to_digits("walk two and a half meters")` -> "walk 2.5 meters". Handles units and tens
("twenty five", "twenty-five"), hundreds and thousands, "and a half" / "and a quarter"
("one and a half", "a meter and a half"), "half a"/"a half" (0.5), "point" decimals
("one point five"), "a"/"an" before a unit ("a meter" -> 1 meter), "a couple (of)" (2),
"a few"/"several" (3), "a dozen" (12), "1/2"-style fractions, and repetition words ("once",
"twice", "thrice", "x3", "3x" -> "N times"). Pure string functions, no state.
"""

from __future__ import annotations

import re


def _words(text: str) -> frozenset[str]:
    """The whitespace-separated words of `text`."""
    return frozenset(text.split())


UNITS: dict[str, int] = {
    "zero": 0, "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8, "nine": 9,
    "ten": 10, "eleven": 11, "twelve": 12, "thirteen": 13, "fourteen": 14, "fifteen": 15, "sixteen": 16,
    "seventeen": 17, "eighteen": 18, "nineteen": 19,
}  # fmt: skip
TENS: dict[str, int] = {"twenty": 20, "thirty": 30, "forty": 40, "fifty": 50, "sixty": 60, "seventy": 70, "eighty": 80, "ninety": 90}
SCALES: dict[str, int] = {"hundred": 100, "thousand": 1000}

# Words after which "a"/"an" means one: units of distance, time, angle and counting.
UNIT_WORDS = _words(
    "meter meters metre metres m centimeter centimeters centimetre centimetres cm foot feet ft yard yards "
    "step steps pace paces stride strides second seconds sec secs minute minutes min mins degree degrees "
    "turn turns rotation rotations time times hundred thousand"
)

_REPEAT_WORDS = {"once": 1, "twice": 2, "thrice": 3}


def format_number(value: float) -> str:
    """A number as the digits the quantity patterns read: 2.0 -> "2", 2.5 -> "2.5"."""
    return f"{value:.6g}"


def _read_integer(tokens: list[str], i: int) -> tuple[float, int] | None:
    """A spelled-out whole number starting at tokens[i]: (value, tokens consumed), or None."""
    total = 0
    current = 0
    j = i
    seen = False
    while j < len(tokens):
        t = tokens[j]
        if t in UNITS:
            if seen and current % 10 != 0 and current < 100:  # "two three" are two numbers
                break
            if seen and current >= 20 and current % 100 != 0 and current % 10 != 0:
                break
            current += UNITS[t]
        elif t in TENS:
            if seen and current % 100 != 0:
                break
            current += TENS[t]
        elif t in SCALES and seen:
            current = max(current, 1) * SCALES[t]
            if SCALES[t] >= 1000:
                total += current
                current = 0
        elif t == "and" and seen and j + 1 < len(tokens) and (tokens[j + 1] in UNITS or tokens[j + 1] in TENS) and current >= 100:
            pass  # "one hundred and twenty"
        else:
            break
        seen = True
        j += 1
    if not seen:
        return None
    return float(total + current), j - i


def _fraction_after(tokens: list[str], j: int) -> tuple[float, int]:
    """ "and a half" / "and a quarter" / "point five" after a number: (fraction, tokens consumed)."""
    if tokens[j : j + 3] == ["and", "a", "half"]:
        return 0.5, 3
    if tokens[j : j + 3] == ["and", "a", "quarter"]:
        return 0.25, 3
    if j < len(tokens) and tokens[j] == "point" and j + 1 < len(tokens):
        digits = []
        k = j + 1
        while k < len(tokens) and ((tokens[k] in UNITS and UNITS[tokens[k]] < 10) or tokens[k].isdigit()):
            digits.append(str(UNITS[tokens[k]]) if tokens[k] in UNITS else tokens[k])
            k += 1
        if digits:
            return float("0." + "".join(digits)), k - j
    return 0.0, 0


def words_to_digits(text: str) -> str:
    """`text` (lower case) with spelled-out numbers written as digits; other words unchanged."""
    text = re.sub(r"(?<=[a-z])-(?=[a-z])", " ", text)  # twenty-five, about-face
    text = re.sub(r"\b(\d+)\s*/\s*(\d+)\b", lambda m: format_number(int(m[1]) / max(int(m[2]), 1)), text)
    text = re.sub(r"\bx\s?(\d+)\b", r"\1 times", text)
    text = re.sub(r"\b(\d+)\s?x\b", r"\1 times", text)
    tokens = text.split()
    out: list[str] = []
    i = 0
    while i < len(tokens):
        t = tokens[i]
        nxt = tokens[i + 1] if i + 1 < len(tokens) else ""
        nxt2 = tokens[i + 2] if i + 2 < len(tokens) else ""
        if t in _REPEAT_WORDS:
            out += [str(_REPEAT_WORDS[t]), "times"]
            i += 1
            continue
        if t in ("a", "an") and nxt == "couple":
            out.append("2")
            i += 3 if nxt2 == "of" else 2
            continue
        if (t == "a" and nxt == "few") or t == "several":
            out.append("3")
            i += 1 if t == "several" else 2
            continue
        if t in ("a", "one") and nxt == "dozen":
            out.append("12")
            i += 2
            continue
        if t == "half" and nxt in ("a", "an") and nxt2 in UNIT_WORDS and nxt2 not in ("turn", "turns", "rotation", "rotations"):
            out.append("0.5")  # "half a meter" (but "half a turn" stays words)
            i += 2
            continue
        if t in ("a", "an") and nxt == "half" and nxt2 in UNIT_WORDS and nxt2 not in ("turn", "turns", "rotation", "rotations"):
            out.append("0.5")  # "a half meter"
            i += 2
            continue
        if t in ("a", "an") and nxt in SCALES:
            tokens[i] = "one"  # "a hundred" reads as "one hundred"
            continue
        if t in ("a", "an") and nxt in UNIT_WORDS and nxt not in ("turn", "turns", "rotation", "rotations", "time", "times"):
            # "a meter" -> 1 meter; "a meter and a half" -> 1.5 meter
            frac, fused = _fraction_after(tokens, i + 2)
            out += [format_number(1.0 + frac), nxt]
            i += 2 + fused
            continue
        read = _read_integer(tokens, i)
        if read is not None:
            value, used = read
            frac, fused = _fraction_after(tokens, i + used)
            out.append(format_number(value + frac))
            i += used + fused
            if fused == 0 and i < len(tokens) and tokens[i] in UNIT_WORDS:
                # "two meters and a half"
                out.append(tokens[i])
                i += 1
                frac2, f2 = _fraction_after(tokens, i)
                if frac2:
                    out[-2] = format_number(value + frac2)
                    i += f2
            continue
        m = re.fullmatch(r"(\d+(?:\.\d+)?)", t)
        if m:
            frac, fused = _fraction_after(tokens, i + 1)
            if fused and tokens[i + 1] == "and":
                out.append(format_number(float(m[1]) + frac))
                i += 1 + fused
                continue
        out.append(t)
        i += 1
    return " ".join(out)
