"""Why words the lexicon does not have are refused: the nearest behaviour by the sentence encoder.

The encoder never decides what runs (`resolve.py`); it only makes a refusal useful. The
typed clause's words are embedded and compared with a short description of each thing the
robot can and cannot do; the nearest, if it is near enough, is named in the refusal:
"kick the ball" -> 'closest to: kicking (standing on one foot) is beyond ...', "stroll
around the room" -> "the nearest it can do is walking; say it with a distance".
"""

from __future__ import annotations

import contextlib
import weakref
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from controller.text.grammar import UnknownWords, refuse
from controller.text.lexicon import REASONS
from controller.text.program import PromptRefused

if TYPE_CHECKING:
    from controller.text.resolve import TextEncoder

# Below this cosine similarity the nearest description is not named. Measured on words outside the
# lexicon: "boot the football" -> kicking 0.61, "greet the crowd with a flourish" -> waving 0.59; wrong
# ones stay below: "perambulate forward" -> reaching 0.55, "do the robot" -> crawling 0.46.
SIMILARITY_THRESHOLD = 0.56

# One description per thing it can do (how to say it) and per reason it refuses.
CAN_DO: dict[str, str] = {
    "walking": "walk forward, backward or sideways",
    "turning": "turn left or right, rotate, spin around",
    "a curved path": "walk in a circle, an arc or a figure eight",
    "waving": "wave your hand, greet someone",
    "raising the arms": "raise your arms, put your hands up",
    "pointing": "point ahead with your arm",
    "reaching": "reach forward with your arm",
    "crossing the arms": "cross your arms",
    "hands on hips": "put your hands on your hips",
    "standing still": "wait, pause, stand still",
    "going back to the start": "come back to where you started",
}
CANNOT: dict[str, str] = {
    "jump": "jump, hop, leap", "run": "run, sprint, jog", "sit": "sit down on a chair", "lie": "lie down, sleep",
    "crawl": "crawl on the floor", "kick": "kick a ball", "strike": "punch, hit, strike, fight", "climb": "climb stairs",
    "dance": "dance", "flip": "do a backflip or a cartwheel", "fly": "fly, swim", "exercise": "do push ups, squat, kneel, bow",
    "head": "nod, look around, move your head", "torso": "lean, bend, twist your body", "speech": "speak, sing, tell a joke",
    "other_gesture": "clap, salute, thumbs up, shake hands", "manipulate": "pick up, carry, throw, open, push an object",
    "style": "walk in a funny style, march, tiptoe", "perception": "go to a place or a person you see, follow someone",
}  # fmt: skip

_BANKS: weakref.WeakKeyDictionary[object, tuple[list[str], NDArray[np.float32]]] = weakref.WeakKeyDictionary()


def _bank(encoder: TextEncoder) -> tuple[list[str], NDArray[np.float32]]:
    with contextlib.suppress(TypeError):
        cached = _BANKS.get(encoder)
        if cached is not None:
            return cached
    keys = [f"can:{k}" for k in CAN_DO] + [f"cannot:{k}" for k in CANNOT]
    vectors = np.asarray(encoder.embed([*CAN_DO.values(), *CANNOT.values()]), dtype=np.float32)
    with contextlib.suppress(TypeError):  # an encoder that cannot be weakly referenced is not cached
        _BANKS[encoder] = (keys, vectors)
    return keys, vectors


def nearest(text: str, encoder: TextEncoder) -> tuple[str, float]:
    """The description key nearest to `text` ("can:walking", "cannot:kick") and its cosine similarity."""
    keys, vectors = _bank(encoder)
    v = np.asarray(encoder.embed([text]), dtype=np.float32)[0]
    scores = vectors @ v
    best = int(np.argmax(scores))
    return keys[best], float(scores[best])


def explain_unknown(unknown: UnknownWords, encoder: TextEncoder) -> PromptRefused:
    """The refusal of `unknown`'s words, with what the prompt is closest to where that is clear."""
    key, score = nearest(unknown.prompt, encoder)
    quoted = ", ".join(f'"{w}"' for w in unknown.words)
    verb = "is not a word" if len(unknown.words) == 1 else "are not words"
    hint = ""
    if score >= SIMILARITY_THRESHOLD:
        kind, name = key.split(":", 1)
        hint = f' (closest to {name}: say it as "{CAN_DO[name]}")' if kind == "can" else f" (closest to: {REASONS[name]})"
    return refuse(unknown.prompt, f"{quoted} {verb} it can act on{hint}")
