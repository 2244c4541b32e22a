"""Paraphrases of motion captions: seeded, varied, and keeping the words that carry the meaning."""

from __future__ import annotations

import re

import numpy as np

from controller.text.paraphrase import mirror_caption, paraphrase, paraphrases

CAPTIONS = (
    "walk forward slowly while waving the right hand",
    "turn left in place",
    "step sideways to the right",
    "walk forward while turning left and pointing to the front right",
    "walk backward and to the left with the left arm raised",
    "stop and stand still with hands on hips",
    "dance salsa",
)


def _sides(text: str) -> list[str]:
    return re.findall(r"\b(left|right)\b", text)


def test_same_seed_same_paraphrases_and_other_seeds_differ() -> None:
    for caption in CAPTIONS:
        assert paraphrases(caption, 8, seed=3) == paraphrases(caption, 8, seed=3)
    assert any(paraphrases(c, 8, seed=3) != paraphrases(c, 8, seed=4) for c in CAPTIONS)
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    assert [paraphrase(c, rng_a) for c in CAPTIONS] == [paraphrase(c, rng_b) for c in CAPTIONS]


def test_paraphrases_are_varied_and_start_with_the_caption() -> None:
    for caption in CAPTIONS:
        texts = paraphrases(caption, 10, seed=0)
        assert texts[0] == caption and len(set(texts)) == len(texts) >= 6, texts
    words = {w for c in CAPTIONS for t in paraphrases(c, 10, seed=0) for w in t.replace(",", "").split()}
    assert {"go", "move", "please", "could"} <= words  # verb synonyms and politeness wrappers appear
    walks = paraphrases("walk forward", 12, seed=0)
    assert len({t.split()[0] for t in walks}) >= 4  # many verbs, not one


def test_meaning_words_are_kept() -> None:
    for caption in CAPTIONS:
        for text in paraphrases(caption, 12, seed=1):
            assert sorted(_sides(text)) == sorted(_sides(caption)), (caption, text)  # left/right never change
            if "backward" in caption:
                assert "backward" in text or "back up" in text, (caption, text)
            elif "forward" in caption:
                assert "forward" in text or "ahead" in text, (caption, text)
    for text in paraphrases("walk forward 2.5 meters then turn left 90 degrees", 12, seed=0):
        assert "2.5" in text and "90" in text and "left" in text
    slow = paraphrases("walk forward slowly", 12, seed=0)
    assert all("quick" not in t and "fast" not in t for t in slow)
    assert any("slow" not in t for t in slow)  # the speed word itself gets synonyms


def test_mirror_caption_swaps_sides_only() -> None:
    assert mirror_caption("turn left in place while pointing to the front right") == "turn right in place while pointing to the front left"
    assert mirror_caption("dance salsa") == "dance salsa"
    assert mirror_caption(mirror_caption(CAPTIONS[3])) == CAPTIONS[3]
