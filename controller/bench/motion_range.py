"""The range of the motion data: where the plausibility thresholds of `controller.planner.plausibility` come from.

Usage:
    python -m controller.bench.motion_range --data ../shared/data/g1-moves [--data data/rec] [--csv-fps 60]

Each `--data` is a folder of 36-column G1 CSV clips (read at `--csv-fps` and resampled to 30 fps,
as `g1ctl dataset import` does) or a dataset folder (`manifest.json`, every split). It prints, as
JSON, the largest pelvis tilt, root-height change within a plan's span and from frame to frame,
and mean planar root speed over a plan's shortest length, each with the clip it comes from, beside
the constants the code uses. Without the data it says so and exits with status 2.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from controller.planner import plausibility
from controller.planner.request import FPS, MAX_LENGTH, MIN_LENGTH
from hw.errors import ConfigError
from hw.types import FloatArray


def load_motion(paths: Sequence[Path], csv_fps: float) -> list[tuple[str, FloatArray]]:
    """(name, qpos [T, 36] at 30 fps) of every clip under `paths`."""
    clips: list[tuple[str, FloatArray]] = []
    for path in paths:
        if (path / "manifest.json").is_file():
            from controller.motion_data.dataset import load_dataset  # noqa: PLC0415

            clips += [(clip.name, clip.qpos) for clip in load_dataset(path)]
            continue
        files = sorted(path.rglob("*.csv")) if path.is_dir() else []
        if not files:
            raise ConfigError(f"no motion data at {path}: pass --data with a folder of G1 CSV clips or a dataset folder")
        from controller.motion_data.csv_import import read_csv_clip  # noqa: PLC0415

        clips += [(file.stem, read_csv_clip(file, csv_fps)) for file in files]
    return clips


def motion_range(clips: Sequence[tuple[str, FloatArray]]) -> dict[str, Any]:
    """The largest values of what `plausibility` bounds, over every frame of `clips` (rounded up to 4 decimals), and the clip of each."""
    found: dict[str, tuple[float, str]] = {}

    def keep(key: str, value: float, name: str) -> None:
        if value > found.get(key, (-1.0, ""))[0]:
            found[key] = (value, name)

    for name, qpos in clips:
        q = np.asarray(qpos, dtype=np.float64)
        height, xy = q[:, 2], q[:, :2]
        keep("tilt_deg", float(plausibility.tilt_deg(q).max()), name)
        for k in range(1, min(MAX_LENGTH, len(q) - 1) + 1):
            change = float(np.abs(height[k:] - height[:-k]).max())
            keep("height_change_m", change, name)
            if k == 1:
                keep("height_step_m", change, name)
            if k >= MIN_LENGTH:
                keep("reach_speed_mps", float(np.linalg.norm(xy[k:] - xy[:-k], axis=1).max()) / k * FPS, name)
    return {
        "clips": len(clips),
        "frames": int(sum(len(q) for _, q in clips)),
        "range": {key: {"value": math.ceil(value * 1e4) / 1e4, "clip": name} for key, (value, name) in sorted(found.items())},
        "constants": {
            "tilt_deg": plausibility.MAX_TILT_DEG,
            "height_change_m": plausibility.MAX_HEIGHT_CHANGE_M,
            "height_step_m": plausibility.MAX_HEIGHT_STEP_M,
            "reach_speed_mps": plausibility.MAX_REACH_SPEED_MPS,
        },
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m controller.bench.motion_range", description=__doc__.split("\n")[0])
    parser.add_argument("--data", type=Path, action="append", required=True, help="CSV clip folder or dataset folder (repeat)")
    parser.add_argument("--csv-fps", type=float, default=60.0, help="frame rate of the CSV clips (G1 Moves: 60)")
    args = parser.parse_args(argv)
    try:
        clips = load_motion(args.data, args.csv_fps)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(motion_range(clips), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
