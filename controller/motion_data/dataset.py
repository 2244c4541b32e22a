"""The planner's motion dataset: G1 clips at 30 fps with contacts, commands, gestures and captions.

A dataset is a folder of compressed `.npz` shards, one per clip, and a `manifest.json`:

    {"version": 1, "fps": 30, "seed": S, "joint_names": [...29...], "qpos_layout": "...",
     "gestures": ["none", "wave", ...],
     "clips": [{"file": "NAME.npz", "name": NAME, "split": "train", "frames": T, "source": "record", "seed": s}, ...]}

A shard holds `qpos` [T, 36] float32 (root xyz, root quaternion w,x,y,z, 29 joints in
`joint_names` order), `contacts` [T, 2] uint8 (left, right foot), `caption_frames` [K]
int32 and `captions` [K] str (the frame each caption starts at), and, for recorded clips,
`command` [T, 3] float32 (vx, vy in m/s in the heading frame, yaw rate in rad/s) and
`gesture` [T] int16 (index into `gestures`).

Split rule: a clip's split follows its seed (`split_for_seed`): seed % 10 == 0 is test,
== 1 is validation, anything else train. A recorded episode's seed is `run_seed * 1000 +
episode index` (`episode_seed`), so every tenth episode of a run is test and the next one
validation. An imported clip's seed is a stable hash of its file name (`name_seed`).

Pure numpy: this module is read by training code and must not import MuJoCo.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from controller.commands.gestures import GESTURE_LABELS
from controller.planner.request import FPS  # clips are at the planner contract's frame rate
from hw.errors import ConfigError
from hw.g1 import JOINT_NAMES, NUM_JOINTS, QPOS_SIZE

FloatArray = NDArray[np.float64]

FORMAT_VERSION = 1
MANIFEST = "manifest.json"
SPLITS = ("train", "val", "test")
QPOS_LAYOUT = "root position xyz (m, z up), root quaternion w,x,y,z, 29 joint angles (rad) in joint_names order"
EPISODES_PER_RUN_SEED = 1000

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


@dataclass(frozen=True)
class MotionClip:
    """One clip: `qpos` [T, 36] at `fps`, foot contacts [T, 2] (left, right) and optional labels."""

    name: str
    qpos: FloatArray
    contacts: NDArray[np.bool_]
    split: str
    fps: float = FPS
    command: FloatArray | None = None  # [T, 3]: vx, vy (m/s, heading frame), yaw rate (rad/s)
    gesture: NDArray[np.int16] | None = None  # [T]: index into GESTURE_LABELS
    captions: tuple[tuple[int, str], ...] = ()  # (first frame of the segment, caption), by frame
    source: str = "record"  # "record" or "csv:<file name>"
    seed: int | None = None  # the seed the split follows (episode seed, or name hash of an import)

    def __post_init__(self) -> None:
        where = f"motion clip '{self.name}'"
        if not _NAME_RE.match(self.name):
            raise ConfigError(f"{where}: names may hold only letters, digits, '_', '.' and '-' (they become file names)")
        if self.qpos.ndim != 2 or self.qpos.shape[1] != QPOS_SIZE or len(self.qpos) < 1:
            raise ConfigError(f"{where}: qpos must be [T, {QPOS_SIZE}], got shape {list(self.qpos.shape)}")
        frames = len(self.qpos)
        if self.contacts.shape != (frames, 2):
            raise ConfigError(f"{where}: contacts must be [{frames}, 2], got shape {list(self.contacts.shape)}")
        if self.split not in SPLITS:
            raise ConfigError(f"{where}: unknown split '{self.split}' (valid: {', '.join(SPLITS)})")
        if self.command is not None and self.command.shape != (frames, 3):
            raise ConfigError(f"{where}: command must be [{frames}, 3], got shape {list(self.command.shape)}")
        if self.gesture is not None and (
            self.gesture.shape != (frames,) or not 0 <= int(self.gesture.min()) <= int(self.gesture.max()) < len(GESTURE_LABELS)
        ):
            raise ConfigError(f"{where}: gesture must be [{frames}] indices below {len(GESTURE_LABELS)}")
        if any(not 0 <= frame < frames for frame, _ in self.captions):
            raise ConfigError(f"{where}: a caption starts outside the clip's {frames} frames")

    @property
    def frames(self) -> int:
        return len(self.qpos)

    @property
    def seconds(self) -> float:
        return self.frames / self.fps


def split_for_seed(seed: int) -> str:
    """The split of a clip with this seed: seed % 10 == 0 -> "test", == 1 -> "val", else "train"."""
    rest = int(seed) % 10
    return "test" if rest == 0 else "val" if rest == 1 else "train"


def episode_seed(run_seed: int, index: int) -> int:
    """Seed of the `index`-th episode of a recording run (distinct across runs below 1000 episodes)."""
    return int(run_seed) * EPISODES_PER_RUN_SEED + int(index)


def name_seed(file_name: str) -> int:
    """A stable seed from a clip's file name (first 4 bytes of its SHA-256): the split of imports."""
    return int.from_bytes(hashlib.sha256(file_name.encode()).digest()[:4], "big")


# --- saving and loading ---------------------------------------------------------------------


def save_dataset(out_dir: str | Path, clips: Sequence[MotionClip], seed: int | None, extra: dict[str, Any] | None = None) -> Path:
    """Write one compressed shard per clip and the manifest (last, atomically); returns the manifest path.

    Shards named by a previous manifest in `out_dir` and not rewritten are removed.
    `extra` adds top-level manifest keys (e.g. the recording's policy and fall count).
    """
    out = Path(out_dir)
    names = [c.name for c in clips]
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise ConfigError(f"two clips share a name {dup[:3]}; clip names become file names in {out}")
    bad_fps = [c.name for c in clips if not math.isclose(c.fps, FPS)]
    if bad_fps:
        raise ConfigError(f"clips {bad_fps[:3]} are not at {FPS:g} fps; resample them first (csv_import.resample_qpos)")
    out.mkdir(parents=True, exist_ok=True)
    old = _old_shards(out)
    entries = []
    for clip in clips:
        file = f"{clip.name}.npz"
        arrays: dict[str, Any] = {
            "qpos": clip.qpos.astype(np.float32),
            "contacts": clip.contacts.astype(np.uint8),
            "caption_frames": np.array([f for f, _ in clip.captions], dtype=np.int32),
            "captions": np.array([c for _, c in clip.captions], dtype=np.str_),
        }
        if clip.command is not None:
            arrays["command"] = clip.command.astype(np.float32)
        if clip.gesture is not None:
            arrays["gesture"] = clip.gesture.astype(np.int16)
        np.savez_compressed(out / file, **arrays)
        entries.append(
            {"file": file, "name": clip.name, "split": clip.split, "frames": clip.frames, "source": clip.source, "seed": clip.seed}
        )
    manifest: dict[str, Any] = {
        "version": FORMAT_VERSION,
        "fps": int(FPS),
        "seed": seed,
        "joint_names": list(JOINT_NAMES),
        "qpos_layout": QPOS_LAYOUT,
        "gestures": list(GESTURE_LABELS),
        **(extra or {}),
        "clips": entries,
    }
    tmp = out / (MANIFEST + ".tmp")
    tmp.write_text(json.dumps(manifest, indent=1) + "\n")
    os.replace(tmp, out / MANIFEST)
    for stale in old - {e["file"] for e in entries}:
        (out / stale).unlink(missing_ok=True)
    return out / MANIFEST


def read_manifest(path: str | Path) -> tuple[Path, dict[str, Any]]:
    """The dataset folder and its checked manifest; `path` is the folder or its manifest.json."""
    p = Path(path)
    folder, manifest_path = (p.parent, p) if p.suffix == ".json" else (p, p / MANIFEST)
    if not manifest_path.is_file():
        raise ConfigError(f"{manifest_path}: no dataset manifest; make a dataset with 'g1ctl dataset record' or 'g1ctl dataset import'")
    try:
        manifest = json.loads(manifest_path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigError(f"{manifest_path}: not a valid JSON manifest ({exc})".splitlines()[0]) from exc
    if not isinstance(manifest, dict):
        raise ConfigError(f"{manifest_path}: the manifest must be a JSON object")
    if manifest.get("version") != FORMAT_VERSION:
        raise ConfigError(
            f"{manifest_path}: unknown dataset version {manifest.get('version')!r} (this g1ctl reads version {FORMAT_VERSION})"
        )
    if manifest.get("joint_names") != list(JOINT_NAMES):
        raise ConfigError(f"{manifest_path}: joint_names differ from the G1's {NUM_JOINTS} joints in the standard order")
    if manifest.get("fps") != FPS:
        raise ConfigError(f"{manifest_path}: fps is {manifest.get('fps')!r}, expected {FPS:g}")
    gestures = manifest.get("gestures")
    if not isinstance(gestures, list) or list(GESTURE_LABELS[: len(gestures)]) != gestures:
        raise ConfigError(f"{manifest_path}: gestures {gestures!r} do not match this g1ctl's {list(GESTURE_LABELS)}")
    clips = manifest.get("clips")
    keys = {"file", "name", "split", "frames", "source"}
    if not isinstance(clips, list) or not all(isinstance(c, dict) and keys <= set(c) for c in clips):
        raise ConfigError(f"{manifest_path}: 'clips' must be a list of objects with {sorted(keys)}")
    for entry in clips:
        if entry["split"] not in SPLITS:
            raise ConfigError(f"{manifest_path}: clip '{entry['name']}' has unknown split {entry['split']!r} (valid: {', '.join(SPLITS)})")
    return folder, manifest


def load_dataset(path: str | Path, split: str | None = None) -> list[MotionClip]:
    """The clips of a dataset folder (or its manifest.json), all or those of one split, in manifest order."""
    if split is not None and split not in SPLITS:
        raise ConfigError(f"unknown split '{split}' (valid: {', '.join(SPLITS)})")
    folder, manifest = read_manifest(path)
    return [_load_clip(folder, entry) for entry in manifest["clips"] if split is None or entry["split"] == split]


def _load_clip(folder: Path, entry: dict[str, Any]) -> MotionClip:
    shard = folder / str(entry["file"])
    try:
        with np.load(shard, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{shard}: cannot read the shard ({exc})".splitlines()[0]) from exc
    missing = {"qpos", "contacts"} - set(data)
    if missing:
        raise ConfigError(f"{shard}: the shard lacks {sorted(missing)}")
    qpos = data["qpos"].astype(np.float64)
    if len(qpos) != entry["frames"]:
        raise ConfigError(f"{shard}: holds {len(qpos)} frames, the manifest says {entry['frames']}")
    frames = data.get("caption_frames", np.zeros(0, np.int32))
    texts = data.get("captions", np.zeros(0, np.str_))
    return MotionClip(
        name=str(entry["name"]),
        qpos=qpos,
        contacts=data["contacts"].astype(bool),
        split=str(entry["split"]),
        fps=FPS,
        command=data["command"].astype(np.float64) if "command" in data else None,
        gesture=data["gesture"].astype(np.int16) if "gesture" in data else None,
        captions=tuple((int(f), str(c)) for f, c in zip(frames, texts, strict=True)),
        source=str(entry["source"]),
        seed=None if entry.get("seed") is None else int(entry["seed"]),
    )


def _old_shards(folder: Path) -> set[str]:
    try:
        manifest = json.loads((folder / MANIFEST).read_text())
        return {str(c["file"]) for c in manifest["clips"] if Path(str(c["file"])).name == c["file"]}
    except (OSError, ValueError, KeyError, TypeError):
        return set()


def dataset_summary(path: str | Path) -> dict[str, Any]:
    """Clips and minutes per split, clips per source, and seconds per gesture label (recorded clips)."""
    folder, manifest = read_manifest(path)
    clips = load_dataset(folder)
    gesture_frames = np.zeros(len(GESTURE_LABELS), dtype=np.int64)
    for clip in clips:
        if clip.gesture is not None:
            gesture_frames += np.bincount(clip.gesture, minlength=len(GESTURE_LABELS))
    sources: dict[str, int] = {}
    for clip in clips:
        kind = clip.source.split(":")[0]
        sources[kind] = sources.get(kind, 0) + 1
    return {
        "path": str(folder),
        "version": manifest["version"],
        "fps": manifest["fps"],
        "seed": manifest.get("seed"),
        "clips": {s: sum(c.split == s for c in clips) for s in SPLITS},
        "minutes": minutes_per_split(clips),
        "frames": sum(c.frames for c in clips),
        "sources": sources,
        "gesture_seconds": {name: round(float(n) / FPS, 1) for name, n in zip(GESTURE_LABELS, gesture_frames, strict=True)},
    }


def minutes_per_split(clips: Sequence[MotionClip]) -> dict[str, float]:
    """Minutes of motion in each split."""
    return {s: round(sum(c.seconds for c in clips if c.split == s) / 60.0, 2) for s in SPLITS}
