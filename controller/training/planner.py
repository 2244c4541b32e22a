"""`g1ctl train planner`: fit the in-betweening model on CPU, checkpointed and resumable, then export ONNX.

The model is conditional flow matching in a compact linear latent: the residual over the
anchor curve (64 frames x 38 values) is standardized per channel and projected on its
leading principal components (fitted on training windows; whitened). A small MLP learns the
velocity field from Gaussian noise to that latent given the conditioning vector; sampling
integrates it in a few Euler steps. Why: a latent of ~100 numbers makes each step a few
hundred thousand multiply-adds (milliseconds on one CPU core for a whole plan), the
flow gives different plausible motions per seed, and the anchor curve meets the
constraints exactly whatever is sampled. Requires torch (`pip install -e .[train]`).

Text: each window's caption in force (imported clips: named from their file,
`controller.training.captions`) is replaced by a random paraphrase, embedded with the
all-MiniLM-L6-v2 sentence encoder (every distinct string once, before training; cached in
the run folder as `text_table.npz`), and left out at `text_dropout` so untexted requests
stay served. Imported (motion capture) clips are also used mirrored left-right.
"""

from __future__ import annotations

import json
import logging
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn
from tqdm import tqdm

from controller.motion_data import styles
from controller.motion_data.csv_import import resample_qpos
from controller.motion_data.dataset import FPS, MotionClip, load_dataset
from controller.motion_data.mirror import mirror_contacts, mirror_qpos
from controller.planner import encoding as enc
from controller.planner.request import TEXT_EMBEDDING_DIM, TEXT_ENCODER
from controller.text.paraphrase import mirror_caption
from controller.training.captions import TextTable, mocap_caption
from controller.training.windows import TrainClip, WindowSampler
from hw.errors import ConfigError

log = logging.getLogger(__name__)

CHECKPOINT = "checkpoint.pt"
ONNX_FILE = "planner.onnx"
SPEC_FILE = "planner.json"
TEXT_TABLE = "text_table.npz"
MODEL_KEYS = (  # a resumed run may change the rest (steps, threads, sampling)
    "batch", "lr", "width", "depth", "latent", "pca_windows", "seed", "data_weights", "mirror_imports", "text_dropout",
    "text_variants", "free_share", "hold_out", "velocity_share", "velocity_fade_frames", "momentum_with_velocity",
    "velocity_fade_delay_frames", "speed_factors",
)  # fmt: skip
Embed = Callable[[list[str]], np.ndarray]  # strings -> unit sentence embeddings [N, 384]


@dataclass(frozen=True)
class TrainConfig:
    steps: int = 12000
    batch: int = 256
    lr: float = 1e-3
    width: int = 512
    depth: int = 3
    latent: int = 128
    sampling_steps: int = 4
    temperature: float = 0.2  # noise scale at sampling, chosen on the validation splits (MODEL_CARD.md)
    pca_windows: int = 20000
    seed: int = 0
    threads: int = 2
    checkpoint_every: int = 500
    data_weights: tuple[float, ...] = ()  # share of training windows per --data folder, in order (empty: equal shares)
    mirror_imports: bool = True  # also train on imported (motion capture) clips mirrored left-right
    text_dropout: float = 0.3  # share of windows trained without text; 1 trains no text at all
    text_variants: int = 12  # paraphrases per caption (the caption itself included)
    # Share of windows with no constraint at all (plans from the context and text alone). 0.1 cost 3 % of l2p on
    # held-out motion capture at 45 frames (validation, full runs); the text still moves unconstrained plans without.
    free_share: float = 0.0
    # Clip name patterns (controller.motion_data.styles) left out of every split: the style validation is scored on.
    hold_out: tuple[str, ...] = ()
    velocity_share: float = 0.3  # windows whose keyframes carry their true velocity (Keyframe.velocity), when the data has it
    # The anchor's velocity terms fade over this many frames (None: never); 16 chosen on capture validation (MODEL_CARD.md).
    velocity_fade_frames: float | None = 16.0
    # Windows whose keyframes carry their velocity keep the root's horizontal momentum in the anchor (features.anchor_curve).
    momentum_with_velocity: bool = True
    # ... and carry every velocity whole this many frames before it fades; 8 chosen on dance-B (MODEL_CARD.md).
    velocity_fade_delay_frames: float = 8.0
    speed_factors: tuple[float, ...] = ()  # imported clips also played this many times faster (e.g. 0.8, 1.25)
    residual_gain: float = 1.0  # share of the learned residual the runtime adds to the anchor (planner.json)
    velocity_residual_gain: float | None = None  # the same where a keyframe carries its velocity (None: residual_gain)

    def __post_init__(self) -> None:
        if not 0.0 <= self.text_dropout <= 1.0:
            raise ConfigError(f"text_dropout must be within 0..1, got {self.text_dropout}")
        if self.text_variants < 1:
            raise ConfigError(f"text_variants must be at least 1, got {self.text_variants}")
        if any(not (w > 0 and math.isfinite(w)) for w in self.data_weights):
            raise ConfigError(f"data_weights must be positive numbers, got {list(self.data_weights)}")
        if not 0.0 <= self.velocity_share <= 1.0:
            raise ConfigError(f"velocity_share must be within 0..1, got {self.velocity_share}")
        if self.velocity_fade_frames is not None and not self.velocity_fade_frames > 0:
            raise ConfigError(f"velocity_fade_frames must be positive (or None: no fade), got {self.velocity_fade_frames}")
        if not 0.0 <= self.velocity_fade_delay_frames < 64:
            raise ConfigError(f"velocity_fade_delay_frames must be within 0..63 frames, got {self.velocity_fade_delay_frames}")
        if any(not 0.5 <= k <= 2.0 for k in self.speed_factors):
            raise ConfigError(f"speed_factors must be within 0.5..2 (times faster), got {list(self.speed_factors)}")
        for name in ("residual_gain", "velocity_residual_gain"):
            gain = getattr(self, name)
            if gain is not None and not 0.0 <= gain <= 1.0:
                raise ConfigError(f"{name} must be within 0..1, got {gain}")

    @property
    def text_conditioned(self) -> bool:
        return self.text_dropout < 1.0


class FlowNet(nn.Module):
    """Velocity field v(x_t, t | cond) in the whitened latent; the conditioning is encoded once per plan."""

    cond_mean: torch.Tensor
    cond_std: torch.Tensor

    def __init__(self, cfg: TrainConfig, cond_mean: np.ndarray, cond_std: np.ndarray) -> None:
        super().__init__()
        self.register_buffer("cond_mean", torch.as_tensor(cond_mean, dtype=torch.float32))
        self.register_buffer("cond_std", torch.as_tensor(cond_std, dtype=torch.float32))
        w = cfg.width
        self.cond_in = nn.Sequential(nn.Linear(enc.COND_DIM, w), nn.SiLU(), nn.Linear(w, w))
        self.x_in = nn.Linear(cfg.latent, w)
        self.t_in = nn.Linear(32, w)
        self.blocks = nn.ModuleList(nn.Sequential(nn.SiLU(), nn.Linear(w, w)) for _ in range(cfg.depth))
        self.out = nn.Sequential(nn.SiLU(), nn.Linear(w, cfg.latent))

    def encode(self, cond: torch.Tensor) -> torch.Tensor:
        return self.cond_in((cond - self.cond_mean) / self.cond_std)

    def velocity(self, x: torch.Tensor, t: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
        h = self.x_in(x) + self.t_in(time_embedding(t)) + c
        for block in self.blocks:
            h = h + block(h)
        return self.out(h)


def time_embedding(t: torch.Tensor) -> torch.Tensor:
    freqs = torch.exp(torch.linspace(0.0, math.log(100.0), 16))  # 1 to 100 cycles over t in [0, 1]
    angles = 2 * math.pi * t[:, None] * freqs[None]
    return torch.cat((torch.sin(angles), torch.cos(angles)), dim=-1)


class Sampler(nn.Module):
    """What is exported: noise and conditioning in, residual [B, 64, 38] out (Euler steps unrolled)."""

    mean: torch.Tensor
    basis: torch.Tensor
    scale: torch.Tensor

    def __init__(self, net: FlowNet, steps: int, mean: np.ndarray, basis: np.ndarray, scale: np.ndarray) -> None:
        super().__init__()
        self.net, self.steps = net, steps
        self.register_buffer("mean", torch.as_tensor(mean, dtype=torch.float32))
        self.register_buffer("basis", torch.as_tensor(basis, dtype=torch.float32))  # [K, F*38], whitening folded in
        self.register_buffer("scale", torch.as_tensor(scale, dtype=torch.float32))  # [38]

    def forward(self, cond: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        c = self.net.encode(cond)
        x = noise
        for i in range(self.steps):
            t = torch.full((x.shape[0],), i / self.steps)
            x = x + self.net.velocity(x, t, c) / self.steps
        flat = x @ self.basis + self.mean
        return flat.reshape(-1, enc.FRAMES, enc.OUT_CHANNELS) * self.scale


@dataclass
class LatentCodec:
    """Per-channel scale, then PCA: residual [.., F, 38] <-> whitened latent [.., K]."""

    scale: np.ndarray  # [38]
    mean: np.ndarray  # [F*38]
    components: np.ndarray  # [K, F*38], orthonormal rows
    sigma: np.ndarray  # [K]

    @classmethod
    def fit(cls, residuals: np.ndarray, latent: int) -> tuple[LatentCodec, float]:
        scale = np.sqrt(np.mean(residuals**2, axis=(0, 1))) + 1e-3
        flat = (residuals / scale).reshape(len(residuals), -1)
        mean = flat.mean(axis=0)
        cov = np.cov(flat - mean, rowvar=False)
        eigval, eigvec = np.linalg.eigh(cov)
        order = np.argsort(eigval)[::-1][:latent]
        explained = float(eigval[order].sum() / eigval.sum())
        return cls(scale, mean, eigvec[:, order].T.copy(), np.sqrt(np.maximum(eigval[order], 1e-8))), explained

    def encode(self, residuals: np.ndarray) -> np.ndarray:
        flat = (residuals / self.scale).reshape(len(residuals), -1)
        return ((flat - self.mean) @ self.components.T) / self.sigma

    def decode_basis(self) -> np.ndarray:
        return self.components * self.sigma[:, None]


def train_planner(
    data_dirs: list[Path], out_dir: Path, cfg: TrainConfig = TrainConfig(), progress: bool = True, embed: Embed | None = None
) -> dict[str, object]:
    """Train (or resume) into `out_dir`; write the ONNX planner and its spec. Returns a summary.

    `embed` turns strings into sentence embeddings (default: the shared all-MiniLM-L6-v2 encoder).
    """
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)  # weights, flow noise and times: a run is repeatable on one machine
    out_dir.mkdir(parents=True, exist_ok=True)
    if cfg.data_weights and len(cfg.data_weights) != len(data_dirs):
        raise ConfigError(f"{len(cfg.data_weights)} data weights for {len(data_dirs)} --data folders; give one per folder")
    held_out = _check_hold_out(data_dirs, cfg.hold_out)
    train_clips = _clips(data_dirs, "train", cfg, augment=True)
    val_clips = _clips(data_dirs, "val", cfg, augment=False)
    table = None
    if cfg.text_conditioned:
        captions = {text for group in train_clips + val_clips for clip in group for _, text in clip.captions}
        table = _text_table(out_dir / TEXT_TABLE, captions, cfg, embed)
    weights = cfg.data_weights or None
    train, val = (
        WindowSampler(
            clips,
            group_weights=weights,
            text=table,
            free_share=cfg.free_share,
            velocity_share=cfg.velocity_share,
            fade_frames=cfg.velocity_fade_frames,
            momentum_with_velocity=cfg.momentum_with_velocity,
            velocity_fade_delay=cfg.velocity_fade_delay_frames,
        )
        for clips in (train_clips, val_clips)
    )
    checkpoint_path = out_dir / CHECKPOINT
    started = time.monotonic()
    if checkpoint_path.is_file():
        state = torch.load(checkpoint_path, weights_only=False)
        changed = {k: state["config"].get(k) for k in MODEL_KEYS if state["config"].get(k) != getattr(cfg, k)}
        if changed:
            raise ConfigError(f"{checkpoint_path} holds a model with other settings {changed}; use a new --out or the same settings")
        codec, cond_stats, explained = state["codec"], state["cond_stats"], state["explained"]
        log.info("resuming from step %d", state["step"])
    else:
        state = None
        codec, cond_stats, explained = _fit_statistics(train, cfg)
    net = FlowNet(cfg, *cond_stats)
    optimizer = torch.optim.AdamW(net.parameters(), lr=cfg.lr, weight_decay=1e-4)
    schedule = torch.optim.lr_scheduler.LambdaLR(optimizer, lambda s: _learning_rate_factor(s, cfg.steps))
    rng = np.random.default_rng(cfg.seed + 1)
    step, elapsed_before, history = 0, 0.0, []
    if state is not None:
        net.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        schedule.load_state_dict(state["schedule"])
        rng.bit_generator.state = state["rng"]
        torch.set_rng_state(state["torch_rng"])
        step, elapsed_before, history = state["step"], state["elapsed_s"], state["history"]
    bar = tqdm(total=cfg.steps, initial=step, desc="train planner", disable=not progress, unit="step")
    running = 0.0
    while step < cfg.steps:
        batch = train.sample(rng, cfg.batch)
        x1 = torch.as_tensor(codec.encode(batch.target), dtype=torch.float32)
        loss = _flow_loss(net, x1, torch.as_tensor(batch.cond, dtype=torch.float32))
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        nn.utils.clip_grad_norm_(net.parameters(), 1.0)
        optimizer.step()
        schedule.step()
        step += 1
        running = 0.98 * running + 0.02 * loss.item() if step > 1 else loss.item()
        bar.update(1)
        bar.set_postfix(loss=f"{running:.3f}")
        if step % cfg.checkpoint_every == 0 or step == cfg.steps:
            val_loss, val_no_text = _validation_loss(net, val, codec)
            history.append(
                {"step": step, "train_loss": round(running, 4), "val_loss": round(val_loss, 4), "val_loss_no_text": round(val_no_text, 4)}
            )
            _save_checkpoint(
                checkpoint_path,
                net,
                optimizer,
                schedule,
                rng,
                step,
                elapsed_before + time.monotonic() - started,
                history,
                cfg,
                codec,
                cond_stats,
                explained,
            )
    bar.close()
    elapsed = elapsed_before + time.monotonic() - started
    export_onnx(out_dir, net, codec, cfg)
    summary = {
        "steps": step,
        "train_seconds": round(elapsed, 1),
        "latent_explained_variance": round(explained, 4),
        "history": history[-5:],
        "parameters": sum(p.numel() for p in net.parameters()),
        "text_strings": 0 if table is None else len(table.embeddings),
        "captions": 0 if table is None else len(table.rows),
        "held_out_clips": held_out,
    }
    (out_dir / "training.json").write_text(
        json.dumps(summary | {"config": asdict(cfg), "data": [str(d) for d in data_dirs]}, indent=2) + "\n"
    )
    return summary


def export_onnx(out_dir: Path, net: FlowNet, codec: LatentCodec, cfg: TrainConfig) -> Path:
    sampler = Sampler(net, cfg.sampling_steps, codec.mean, codec.decode_basis(), codec.scale).eval()
    cond = torch.zeros(1, enc.COND_DIM)
    noise = torch.zeros(1, cfg.latent)
    path = out_dir / ONNX_FILE
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # the TorchScript exporter: no extra dependency, exact graph
        torch.onnx.export(
            sampler, (cond, noise), str(path), input_names=["cond", "noise"], output_names=["residual"],
            dynamic_axes={"cond": {0: "batch"}, "noise": {0: "batch"}, "residual": {0: "batch"}}, opset_version=17, dynamo=False,
        )  # fmt: skip
    spec = {
        "version": enc.SPEC_VERSION,
        "onnx": ONNX_FILE,
        "latent": cfg.latent,
        "cond_dim": enc.COND_DIM,
        "frames": enc.FRAMES,
        "out_channels": enc.OUT_CHANNELS,
        "sampling_steps": cfg.sampling_steps,
        "temperature": cfg.temperature,
        "fps": 30,
        "text_encoder": TEXT_ENCODER,
        "text_dim": TEXT_EMBEDDING_DIM,
        "text_conditioned": cfg.text_conditioned,
        "keyframe_velocities": cfg.velocity_share > 0,
        "velocity_fade_frames": cfg.velocity_fade_frames,
        "momentum_with_velocity": cfg.momentum_with_velocity,
        "velocity_fade_delay_frames": cfg.velocity_fade_delay_frames,
        "residual_gain": cfg.residual_gain,
        "velocity_residual_gain": cfg.residual_gain if cfg.velocity_residual_gain is None else cfg.velocity_residual_gain,
        "held_out": list(cfg.hold_out),
        "legs": _leg_chains(),
    }
    (out_dir / SPEC_FILE).write_text(json.dumps(spec, indent=2) + "\n")
    return path


def _leg_chains() -> list[dict[str, Any]]:
    """The G1 leg chains for the runtime's foot locking, read from the same MJCF the data was recorded with."""
    from controller.assets import ensure_assets  # noqa: PLC0415
    from sim.kinematics import leg_chain_specs  # noqa: PLC0415 - imports MuJoCo
    from sim.world import build_model  # noqa: PLC0415

    return leg_chain_specs(build_model(ensure_assets(quiet=True).g1_mjcf))


def training_clips(clip: MotionClip, mirror: bool, speed_factors: tuple[float, ...] = ()) -> list[TrainClip]:
    """A dataset clip as training windows read it; an imported clip captioned from its name, and (if asked)
    mirrored and played at other speeds too."""
    captions = clip.captions
    imported = clip.source.startswith("csv:")
    if imported and not captions:
        captions = ((0, mocap_caption(clip.name)),)
    out = [TrainClip(clip.qpos, clip.contacts.astype(np.float64), captions)]
    if imported and mirror:
        mirrored = tuple((frame, mirror_caption(text)) for frame, text in captions)
        out.append(TrainClip(mirror_qpos(clip.qpos), mirror_contacts(clip.contacts).astype(np.float64), mirrored))
    if imported:
        out += [faster(c, k) for c in list(out) for k in speed_factors]
    return out


def faster(clip: TrainClip, factor: float) -> TrainClip:
    """The clip played `factor` times faster (slower below 1), still at 30 fps: a style's other tempos."""
    qpos = resample_qpos(clip.qpos, FPS * factor, FPS)
    source = np.minimum(np.round(np.arange(len(qpos)) * factor).astype(np.int64), len(clip.qpos) - 1)
    captions = tuple((round(frame / factor), text) for frame, text in clip.captions)
    return TrainClip(qpos, clip.contacts[source], captions)


def _check_hold_out(data_dirs: list[Path], patterns: tuple[str, ...]) -> list[str]:
    """The names of the clips held out; ConfigError for a pattern that matches no clip (a typo holds nothing out)."""
    if not patterns:
        return []
    names = [c.name for d in data_dirs for c in load_dataset(d)]
    missing = styles.unmatched(names, patterns)
    if missing:
        known = ", ".join(styles.folder_prefixes(names))
        raise ConfigError(f"--hold-out {','.join(missing)} matches no clip in {', '.join(map(str, data_dirs))}; their folders: {known}")
    return [n for n in names if styles.matches(n, patterns)]


def _clips(data_dirs: list[Path], split: str, cfg: TrainConfig, augment: bool) -> list[list[TrainClip]]:
    groups = [
        [
            tc
            for c in load_dataset(d, split=split)
            if not styles.matches(c.name, cfg.hold_out)
            for tc in training_clips(c, augment and cfg.mirror_imports, cfg.speed_factors if augment else ())
        ]
        for d in data_dirs
    ]
    if not any(groups):
        raise ConfigError(f"no '{split}' clips in {', '.join(map(str, data_dirs))}; record one with 'g1ctl dataset record'")
    return groups


def _text_table(path: Path, captions: set[str], cfg: TrainConfig, embed: Embed | None) -> TextTable:
    """Paraphrases of every caption, embedded once; reused from `path` when it holds the same strings."""
    cached: dict[str, np.ndarray] = {}
    if path.is_file():
        with np.load(path, allow_pickle=False) as z:
            cached = dict(zip((str(s) for s in z["strings"]), z["embeddings"], strict=True))

    def embed_missing(strings: list[str]) -> np.ndarray:
        missing = [s for s in strings if s not in cached]
        if missing:
            encode = embed if embed is not None else _shared_embed()
            started = time.monotonic()
            vectors = np.asarray(encode(missing), dtype=np.float64)
            if vectors.shape != (len(missing), TEXT_EMBEDDING_DIM):
                raise ConfigError(f"the text encoder returned shape {list(vectors.shape)}, expected [{len(missing)}, {TEXT_EMBEDDING_DIM}]")
            log.info("embedded %d strings in %.1f s", len(missing), time.monotonic() - started)
            cached.update(zip(missing, vectors, strict=True))
        return np.stack([cached[s] for s in strings]) if strings else np.zeros((0, TEXT_EMBEDDING_DIM))

    table, strings = TextTable.build(captions, embed_missing, cfg.text_variants, cfg.text_dropout, cfg.seed)
    np.savez(path, strings=np.array(strings, dtype=np.str_), embeddings=table.embeddings.astype(np.float32))
    return table


def _shared_embed() -> Embed:
    from controller.text.encoder import shared_encoder  # noqa: PLC0415 - loads the encoder's weights

    return shared_encoder().embed


def _fit_statistics(train: WindowSampler, cfg: TrainConfig) -> tuple[LatentCodec, tuple[np.ndarray, np.ndarray], float]:
    rng = np.random.default_rng(cfg.seed)
    batches = [train.sample(rng, 1000) for _ in range(max(cfg.pca_windows // 1000, 1))]
    residuals = np.concatenate([b.target for b in batches])
    conds = np.concatenate([b.cond for b in batches])
    codec, explained = LatentCodec.fit(residuals, cfg.latent)
    log.info("latent of %d components keeps %.1f%% of the residual variance", cfg.latent, 100 * explained)
    return codec, (conds.mean(axis=0), conds.std(axis=0) + 1e-3), explained


def _learning_rate_factor(step: int, total: int) -> float:
    """Linear warm-up over the first 5% of steps, then a cosine decay to zero."""
    warmup = max(total // 20, 1)
    return min(1.0, (step + 1) / warmup) * 0.5 * (1.0 + math.cos(math.pi * min(step / total, 1.0)))


def _flow_loss(net: FlowNet, x1: torch.Tensor, cond: torch.Tensor, generator: torch.Generator | None = None) -> torch.Tensor:
    x0 = torch.randn(x1.shape, generator=generator)
    t = torch.rand(x1.shape[0], generator=generator)
    xt = (1 - t[:, None]) * x0 + t[:, None] * x1
    return torch.mean((net.velocity(xt, t, net.encode(cond)) - (x1 - x0)) ** 2)


def _validation_loss(net: FlowNet, val: WindowSampler, codec: LatentCodec) -> tuple[float, float]:
    """Flow loss on fixed validation windows: as sampled (text where drawn), and with every text slot emptied."""
    batch = val.sample(np.random.default_rng(1234), 1024)
    no_text = batch.cond.copy()
    no_text[:, enc.TEXT_SLOT] = 0.0
    with torch.no_grad():  # its own noise stream: the training stream is left where it was
        x1 = torch.as_tensor(codec.encode(batch.target), dtype=torch.float32)
        losses = [
            float(_flow_loss(net, x1, torch.as_tensor(cond, dtype=torch.float32), torch.Generator().manual_seed(1234)))
            for cond in (batch.cond, no_text)
        ]
    return losses[0], losses[1]


def _save_checkpoint(path: Path, net, optimizer, schedule, rng, step, elapsed, history, cfg, codec, cond_stats, explained) -> None:
    tmp = path.with_suffix(".tmp")
    torch.save(
        {
            "model": net.state_dict(), "optimizer": optimizer.state_dict(), "schedule": schedule.state_dict(),
            "rng": rng.bit_generator.state, "torch_rng": torch.get_rng_state(), "step": step, "elapsed_s": elapsed, "history": history,
            "config": asdict(cfg), "codec": codec, "cond_stats": cond_stats, "explained": explained,
        },
        tmp,
    )  # fmt: skip
    tmp.replace(path)
