"""`g1ctl dataset import`: G1 clips from 36-column CSV files into the motion dataset format.

A CSV row is root xyz, root quaternion x,y,z,w and 29 joint angles, no header, at any
frame rate; clips are resampled to the planner's 30 fps (slerp for the rotation) and
their foot contacts come from forward kinematics (contact point below 5 cm). A clip's
seed is a hash of its file name, so its split never changes. Imports MuJoCo (through
`sim`) only in `import_csv`, for the forward kinematics.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from controller.assets import ensure_assets
from controller.motion_data.dataset import FPS, MotionClip, minutes_per_split, name_seed, save_dataset, split_for_seed
from hw import quat
from hw.errors import ConfigError
from hw.g1 import QPOS_ROOT_QUAT, QPOS_SIZE
from hw.types import FloatArray

CSV_COLUMNS = QPOS_SIZE  # root xyz, root quaternion x,y,z,w, 29 joints


def read_csv_clip(path: str | Path, fps: float) -> FloatArray:
    """A 36-column G1 CSV (root xyz, quaternion x,y,z,w, 29 joints; no header) as qpos [T, 36] at 30 fps.

    Positions and joints are interpolated linearly, the quaternion by slerp after it is
    reordered to w,x,y,z, normalized and made sign-continuous.
    """
    p = Path(path)
    if not math.isfinite(fps) or fps <= 0:
        raise ConfigError(f"{p}: the frame rate must be positive, got {fps:g}")
    try:
        text = p.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: cannot read the CSV ({exc})".splitlines()[0]) from exc
    rows: list[list[float]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        cells = line.split(",")
        if len(cells) != CSV_COLUMNS:
            raise ConfigError(
                f"{p}: line {lineno} has {len(cells)} columns, expected {CSV_COLUMNS} (root xyz, quaternion x,y,z,w, 29 joints)"
            )
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            bad = next(c for c in cells if not _is_float(c))
            raise ConfigError(
                f"{p}: line {lineno} holds a non-numeric value {bad.strip()[:20]!r}; expected numbers only (no header row)"
            ) from None
    if len(rows) < 2:
        raise ConfigError(f"{p}: {len(rows)} frame(s); a clip needs at least 2")
    raw = np.array(rows)
    bad_rows = np.flatnonzero(~np.isfinite(raw).all(axis=1))
    if bad_rows.size:
        raise ConfigError(f"{p}: NaN or infinite values from data row {bad_rows[0] + 1} ({bad_rows.size} rows)")
    qpos = np.concatenate([raw[:, :3], raw[:, 6:7], raw[:, 3:6], raw[:, 7:]], axis=1)  # CSV x,y,z,w -> qpos w,x,y,z
    norms = np.linalg.norm(qpos[:, QPOS_ROOT_QUAT], axis=1)
    if (norms < 1e-6).any():
        raise ConfigError(f"{p}: a zero root quaternion at data row {int(np.argmax(norms < 1e-6)) + 1}")
    qpos[:, QPOS_ROOT_QUAT] /= norms[:, None]
    qpos[:, QPOS_ROOT_QUAT] = quat.continuous(qpos[:, QPOS_ROOT_QUAT])
    return resample_qpos(qpos, fps, FPS)


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def resample_qpos(qpos: FloatArray, fps_in: float, fps_out: float = FPS) -> FloatArray:
    """Frames [T, 36] at `fps_in` -> frames at `fps_out` over the same span (from t = 0, none past the end)."""
    q = np.asarray(qpos, dtype=np.float64)
    n = len(q)
    if n < 2:
        return q.copy()
    count = math.floor((n - 1) / fps_in * fps_out + 1e-9) + 1
    src = np.arange(count) * (fps_in / fps_out)  # positions in source frames
    i0 = np.minimum(np.floor(src + 1e-9).astype(np.int64), n - 2)
    a = np.clip(src - i0, 0.0, 1.0)
    out = q[i0] * (1.0 - a)[:, None] + q[i0 + 1] * a[:, None]
    rot = QPOS_ROOT_QUAT
    out[:, rot] = quat.continuous(quat.slerp(q[i0, rot], q[i0 + 1, rot], a))
    return out


def csv_files(path: str | Path) -> list[Path]:
    """`path` itself when it is a .csv file, else every .csv below it (recursively), sorted."""
    p = Path(path)
    if p.is_file():
        if p.suffix.lower() != ".csv":
            raise ConfigError(f"{p}: not a .csv file")
        return [p]
    if not p.is_dir():
        raise ConfigError(f"{p}: no such file or folder of .csv clips")
    found = sorted(f for f in p.rglob("*") if f.is_file() and f.suffix.lower() == ".csv")
    if not found:
        raise ConfigError(f"{p}: no .csv files in this folder or below")
    return found


def clip_name_for(csv_path: Path, root: Path) -> str:
    """A clip name from a CSV's path below the import root: folders joined by '-', unsafe characters as '_'."""
    rel = csv_path.relative_to(root) if root.is_dir() else Path(csv_path.name)
    stem = "-".join((*rel.parts[:-1], rel.stem))
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", stem).lstrip("._-")
    return name or "clip"


def import_csv_clips(
    files: Iterable[Path], root: Path, fps: float, contacts_of: Callable[[FloatArray], NDArray[np.bool_]]
) -> list[MotionClip]:
    """Read CSV clips into MotionClips; `contacts_of(qpos)` gives the foot contacts [T, 2] (kinematics lives in sim/)."""
    clips = []
    for f in files:
        qpos = read_csv_clip(f, fps)
        seed = name_seed(f.name)
        clips.append(
            MotionClip(
                name=clip_name_for(f, root),
                qpos=qpos,
                contacts=np.asarray(contacts_of(qpos), dtype=bool),
                split=split_for_seed(seed),
                source=f"csv:{f.name}",
                seed=seed,
            )
        )
    return clips


def import_csv(csv: str | Path, out: Path, fps: float = 60.0, assets_dir: str | None = None) -> dict[str, Any]:
    """Import G1 CSV clips (a file or a folder, recursively) at `fps` into a dataset at `out`."""
    from sim.kinematics import G1Kinematics, foot_contacts  # noqa: PLC0415 - MuJoCo, only for the kinematics

    root = Path(csv)
    files = csv_files(root)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out}: exists and is not a folder")
    kinematics = G1Kinematics(ensure_assets(assets_dir).g1_mjcf)

    def contacts_of(qpos: FloatArray) -> NDArray[np.bool_]:
        return foot_contacts(kinematics.forward(qpos)[2])

    clips = import_csv_clips(files, root, fps, contacts_of)
    save_dataset(out, clips, None, extra={"source": "csv", "csv_fps": fps})
    return {"out": str(out), "clips": len(clips), "minutes": minutes_per_split(clips)}
