"""The motion data's range: the script that the plausibility constants come from, re-run on the capture when it is here."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from controller.bench.motion_range import load_motion, main, motion_range
from controller.planner import plausibility
from controller.planner.request import FPS
from hw import g1, quat

ROOT = Path(__file__).resolve().parents[3]
# The g1-moves clips sit beside the repository (../shared/data/g1-moves), or where G1_MOVES_DIR says.
G1_MOVES = Path(os.environ.get("G1_MOVES_DIR", ROOT.parent / "shared" / "data" / "g1-moves"))


def test_the_range_of_known_motion() -> None:
    frames = 100
    qpos = np.tile(np.array(g1.standing_qpos()), (frames, 1))
    qpos[:, 0] = np.arange(frames) * 0.02  # 0.6 m/s forward
    qpos[50:, 2] -= np.minimum(np.arange(50) * 0.01, 0.2)  # sinks 0.01 m a frame, 0.2 m in all
    qpos[70, g1.QPOS_ROOT_QUAT] = quat.from_axis_angle([1.0, 0.0, 0.0], math.radians(25.0))
    dash = np.tile(np.array(g1.standing_qpos()), (30, 1))
    dash[:, 0] = np.arange(30) * 0.05  # 1.5 m/s: faster than `sink`, over 24 frames and more
    found = motion_range([("sink", qpos), ("dash", dash)])
    r = found["range"]
    assert found["clips"] == 2 and found["frames"] == 130
    assert r["tilt_deg"] == {"value": pytest.approx(25.0, abs=1e-3), "clip": "sink"}
    assert r["height_change_m"] == {"value": pytest.approx(0.2, abs=1e-3), "clip": "sink"}
    assert r["height_step_m"] == {"value": pytest.approx(0.01, abs=1e-3), "clip": "sink"}
    assert r["reach_speed_mps"] == {"value": pytest.approx(0.05 * FPS, abs=1e-3), "clip": "dash"}


@pytest.mark.skipif(not G1_MOVES.is_dir(), reason=f"g1-moves clips not at {G1_MOVES} (set G1_MOVES_DIR)")
def test_the_plausibility_constants_are_the_capture_range() -> None:
    found = motion_range(load_motion([G1_MOVES], csv_fps=60.0))
    assert found["clips"] == 32 and found["frames"] == 31_914
    assert {key: entry["value"] for key, entry in found["range"].items()} == found["constants"]
    assert found["constants"]["tilt_deg"] == plausibility.MAX_TILT_DEG


def test_missing_data_is_one_line_and_status_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--data", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: no motion data at") and "\n" not in err
