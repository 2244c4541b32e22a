"""Run and benchmark reports: timing percentiles and JSON files, written one way everywhere."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np


def percentiles_ms(samples_s: Sequence[float]) -> dict[str, float]:
    """p50 and p99 of durations given in seconds, in milliseconds (NaN when there are none)."""
    if not samples_s:
        return {"p50": float("nan"), "p99": float("nan")}
    arr = np.asarray(samples_s) * 1e3
    return {"p50": round(float(np.percentile(arr, 50)), 4), "p99": round(float(np.percentile(arr, 99)), 4)}


def write_report(report: dict[str, Any], path: Path) -> None:
    """Write `report` as indented JSON, creating the folder; replaced atomically so a reader never sees half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".part")
    partial.write_text(json.dumps(report, indent=2) + "\n")
    partial.replace(path)
