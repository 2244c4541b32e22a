"""Seeded paraphrases of motion captions: other words, the same behaviour.

The planner is trained on captions written by the dataset recorder ("walk forward slowly
while waving the right hand") and by `controller.training.captions` for imported clips
("dance salsa"); people type other words. `paraphrase` rewrites a caption with synonyms
for its verbs, directions, speed words and gesture phrases, sometimes moves a gesture to
the front, and sometimes wraps it in a polite request, drawing every choice from the
given random generator. Meaning words stay: left/right, forward/backward, slow/quick,
numbers and any word no rule knows are kept as they are.

`mirror_caption` swaps left and right, for mirrored training clips. Pure Python, no numpy
state of its own: the same seed gives the same paraphrase.
"""

from __future__ import annotations

import re

import numpy as np

_SIDE = r"(left|right)"

# (pattern, alternatives): each match is replaced by one alternative; `{0}`, `{1}` are the pattern's groups.
# Patterns are tried in order on what is left of the caption, longest phrases first.
_RULES: tuple[tuple[str, tuple[str, ...]], ...] = (
    # standing
    (
        r"stop and stand still",
        (
            "stop and stand still",
            "stop and stay still",
            "come to a stop and stand still",
            "halt and stand still",
            "stop walking and stand still",
            "stop and stand",
        ),
    ),
    (r"stand still", ("stand still", "stay still", "stand in place", "hold still", "stay where you are", "keep standing")),
    # speed changes
    (
        r"speed up while walking forward",
        (
            "speed up while walking forward",
            "walk forward faster",
            "pick up the pace walking forward",
            "accelerate while walking forward",
            "go forward faster",
        ),
    ),
    (
        r"slow down while walking forward",
        (
            "slow down while walking forward",
            "walk forward more slowly",
            "ease off the pace walking forward",
            "decelerate while walking forward",
            "go forward slower",
        ),
    ),
    # locomotion
    (
        r"start walking (forward|backward)",
        ("start walking {0}", "begin walking {0}", "start moving {0}", "set off {0}", "begin to walk {0}", "start to go {0}"),
    ),
    (
        r"walk (forward|backward) and to the " + _SIDE,
        (
            "walk {0} and to the {1}",
            "go {0} and to the {1}",
            "move diagonally {0} and to the {1}",
            "walk diagonally {0} to the {1}",
            "head {0} and to the {1}",
        ),
    ),
    (
        r"walk forward",
        ("walk forward", "go forward", "move forward", "head forward", "stroll forward", "walk ahead", "go straight ahead", "step forward"),
    ),
    (r"walk backward", ("walk backward", "go backward", "move backward", "walk backwards", "back up", "step backward", "head backward")),
    (
        r"step sideways to the " + _SIDE,
        (
            "step sideways to the {0}",
            "sidestep to the {0}",
            "move sideways to the {0}",
            "shuffle to the {0}",
            "step to the {0}",
            "walk sideways to the {0}",
        ),
    ),
    (
        r"turn " + _SIDE + r" in place",
        (
            "turn {0} in place",
            "turn {0} on the spot",
            "rotate {0} in place",
            "turn to the {0} without walking",
            "spin {0} on the spot",
            "turn to your {0} in place",
        ),
    ),
    (
        r" while turning " + _SIDE,
        (" while turning {0}", " while veering {0}", " and turn {0}", ", curving to the {0}", " while bearing {0}", " turning {0}"),
    ),
    # speed words
    (r" slowly", (" slowly", " at a slow pace", " gently", " leisurely", " unhurriedly")),
    (r" quickly", (" quickly", " fast", " briskly", " at a quick pace", " rapidly")),
    # imported clips (controller.training.captions.mocap_caption)
    (r"raise both hands", ("raise both hands", "put both hands up", "lift both hands", "raise your hands", "put your hands up")),
    (r"^dance ", ("dance ", "do a dance: ", "perform a dance, ", "dance like this: ")),
)
# Gesture phrases, bare (the caption's connector " while ", " and " or " " is chosen anew): a phrase
# that starts with "with" follows the motion directly, any other one after "while" or "and".
_GESTURES: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        r"waving the " + _SIDE + r" hand",
        ("waving the {0} hand", "waving with the {0} hand", "waving your {0} hand", "with a wave of the {0} hand"),
    ),
    (r"waving both hands", ("waving both hands", "waving with both hands", "waving both arms", "with both hands waving")),
    (
        r"with the " + _SIDE + r" arm raised",
        ("with the {0} arm raised", "with the {0} arm up", "holding the {0} arm up", "raising the {0} arm", "with your {0} arm lifted"),
    ),
    (
        r"with both arms raised",
        ("with both arms raised", "with both arms up", "with arms up", "holding both arms up", "with your arms lifted"),
    ),
    (
        r"reaching forward with the " + _SIDE + r" hand",
        (
            "reaching forward with the {0} hand",
            "reaching out with the {0} hand",
            "stretching the {0} hand forward",
            "reaching ahead with your {0} hand",
        ),
    ),
    (
        r"pointing to the front " + _SIDE,
        ("pointing to the front {0}", "pointing ahead to the {0}", "pointing forward and to the {0}", "pointing front {0}"),
    ),
    (r"with arms crossed", ("with arms crossed", "with the arms folded", "with crossed arms", "folding the arms")),
    (
        r"with hands on hips",
        ("with hands on hips", "with hands on the hips", "with your hands resting on your hips", "keeping the hands on the hips"),
    ),
)
_COMPILED = tuple((re.compile(pattern), alternatives) for pattern, alternatives in _RULES)
_GESTURE_AT_END = tuple(
    (re.compile(r"^(?P<main>.+?)(?: while| and)? (?P<gesture>" + pattern + r")$"), alternatives) for pattern, alternatives in _GESTURES
)
_WRAPPERS = ("{}", "{}", "{}", "please {}", "could you {}", "can you {}", "{} please", "now {}", "i want you to {}", "let us {}")


def paraphrase(caption: str, rng: np.random.Generator) -> str:
    """One paraphrase of `caption`, every choice drawn from `rng`.

    Known phrases get a random synonym; a trailing gesture ("... while waving the right
    hand") moves to the front part of the time; a politeness wrapper part of the time.
    Words no rule knows (numbers, names) are kept in place.
    """
    text = " ".join(caption.lower().split())
    for pattern, alternatives in _GESTURE_AT_END:
        match = pattern.match(text)
        if match:
            main = _substitute(match["main"], rng)
            gesture = alternatives[int(rng.integers(len(alternatives)))].format(*match.groups()[2:])
            gesture = gesture if gesture.startswith("with ") else f"{'and' if ' while ' in main else 'while'} {gesture}"
            if rng.random() < 0.25:  # the gesture first: "while waving the right hand, walk forward"
                text = f"{gesture.removeprefix('and ')}, {main}"
                text = text if text.startswith(("with ", "while ")) else f"while {text}"
            else:
                text = f"{main} {gesture}"
            break
    else:
        text = _substitute(text, rng)
    wrappers = _WRAPPERS if not text.startswith(("with ", "while ")) else ("{}", "{} please", "now {}")
    wrapper = wrappers[int(rng.integers(len(wrappers)))]
    return " ".join(wrapper.format(text).split())


def paraphrases(caption: str, count: int, seed: int) -> list[str]:
    """`caption` itself, then up to `count - 1` distinct paraphrases (fewer when the rules allow fewer)."""
    rng = np.random.default_rng([seed, _stable_hash(caption)])
    out = [caption]
    for _ in range(count * 8):
        if len(out) >= count:
            break
        candidate = paraphrase(caption, rng)
        if candidate not in out:
            out.append(candidate)
    return out


def mirror_caption(caption: str) -> str:
    """The caption of the mirrored motion: left and right swapped."""
    return re.sub(r"\b(left|right)\b", lambda m: "right" if m[1] == "left" else "left", caption)


def _substitute(text: str, rng: np.random.Generator) -> str:
    """Replace every match of the rules, left to right per rule; replaced spans are not rewritten again."""
    pieces: list[tuple[str, bool]] = [(text, False)]  # (text, already replaced)
    for pattern, alternatives in _COMPILED:
        out: list[tuple[str, bool]] = []
        for piece, done in pieces:
            if done:
                out.append((piece, done))
                continue
            last = 0
            for match in pattern.finditer(piece):
                out.append((piece[last : match.start()], False))
                choice = alternatives[int(rng.integers(len(alternatives)))]
                out.append((choice.format(*match.groups()), True))
                last = match.end()
            out.append((piece[last:], False))
        pieces = [(p, d) for p, d in out if p]
    return "".join(p for p, _ in pieces)


def _stable_hash(text: str) -> int:
    value = 0
    for byte in text.encode():
        value = (value * 131 + byte) % (1 << 31)
    return value
