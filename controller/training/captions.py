"""Captions for training windows: names for imported clips, the caption in force, the text table.

Recorded clips carry a caption per command segment (`MotionClip.captions`); imported motion
capture has none, so `mocap_caption` names it from its file name ("J_Dance2_Salsa" ->
"dance salsa"). A training window takes the caption in force over most of its plan frames
(`caption_in_force`). `TextTable` holds, for every caption, the sentence embeddings of the
caption and its paraphrases (`controller.text.paraphrase`), embedded once before training;
`TextTable.draw` gives each window one of them at random, or no text at the dropout rate.
Pure numpy (the encoder is passed in as a function).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from controller.text.paraphrase import paraphrases

FloatArray = NDArray[np.float64]
Captions = tuple[tuple[int, str], ...]  # (first frame, caption), by frame

# Imported clips whose name is no description of the motion by itself.
_MOCAP_NAMES = {
    "hands up": "raise both hands",
    "hands chop": "chop down with both hands",
    "fence": "fence with a sword",
}
_DANCE_PREFIX = re.compile(r"^(?:short)?dance\d*$")


def mocap_caption(name: str) -> str:
    """A caption from an imported clip's name: 'dance-J_Dance2_Salsa' -> 'dance salsa', 'B_HandsUp' -> 'raise both hands'.

    The folder prefix ('dance-', 'bonus-'), the performer prefix ('J_', 'B_'), numbers and
    'Dance<N>' numbering go; CamelCase splits into lower-case words.
    """
    stem = re.sub(r"\.csv$", "", name.split("/")[-1])
    stem = re.sub(r"^(?:dance|bonus)-", "", stem)
    stem = re.sub(r"^[A-Z]_", "", stem)
    parts = [p for p in stem.split("_") if p and not _DANCE_PREFIX.match(p.lower())]
    words = " ".join(re.sub(r"(?<=[a-z])(?=[A-Z])|(?<=[A-Za-z])(?=\d)", " ", p) for p in parts).lower()
    words = " ".join(w for w in words.split() if not w.isdigit())
    if words in _MOCAP_NAMES:
        return _MOCAP_NAMES[words]
    if words.endswith(" dance"):  # "wiggle dance" -> "dance a wiggle dance"
        return f"dance a {words}"
    return f"dance {words}" if words else "dance"


def caption_in_force(captions: Captions, first: int, stop: int, majority: float = 0.5) -> str | None:
    """The caption covering the most of frames [first, stop), if it covers more than `majority` of them; else None."""
    if not captions or stop <= first:
        return None
    best, best_cover = None, 0
    for i, (start, text) in enumerate(captions):
        end = captions[i + 1][0] if i + 1 < len(captions) else stop
        cover = min(end, stop) - max(start, first)
        if cover > best_cover:
            best, best_cover = text, cover
    return best if best_cover > majority * (stop - first) else None


@dataclass(frozen=True)
class TextTable:
    """Sentence embeddings of every caption's variants: `rows[caption]` indexes `embeddings` [V, D]."""

    embeddings: FloatArray
    rows: dict[str, NDArray[np.int64]]
    dropout: float = 0.3

    @classmethod
    def build(
        cls,
        captions: Iterable[str],
        embed: Callable[[list[str]], FloatArray],
        variants: int = 12,
        dropout: float = 0.3,
        seed: int = 0,
    ) -> tuple[TextTable, list[str]]:
        """Paraphrase every distinct caption, embed every distinct string once; also returns the strings in row order."""
        strings: dict[str, int] = {}
        rows: dict[str, NDArray[np.int64]] = {}
        for caption in sorted(set(captions)):
            texts = paraphrases(caption, variants, seed)
            rows[caption] = np.array([strings.setdefault(t, len(strings)) for t in texts], dtype=np.int64)
        ordered = list(strings)
        embeddings = np.asarray(embed(ordered), dtype=np.float64) if ordered else np.zeros((0, 0))
        return cls(embeddings, rows, dropout), ordered

    @property
    def dim(self) -> int:
        return int(self.embeddings.shape[1])

    def draw(self, rng: np.random.Generator, captions: Sequence[str | None]) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Per window: a random variant of its caption, or no text (no caption, or dropped): text [B, D], present [B]."""
        text = np.zeros((len(captions), self.dim))
        present = np.zeros(len(captions), dtype=bool)
        keep = rng.random(len(captions)) >= self.dropout
        for b, caption in enumerate(captions):
            choices = self.rows.get(caption) if caption is not None else None
            if choices is None or not keep[b]:
                continue
            text[b] = self.embeddings[choices[int(rng.integers(len(choices)))]]
            present[b] = True
        return text, present
