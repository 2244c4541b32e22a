"""`g1ctl bench gestures` end to end, in a subprocess: the detector scored on executed clauses, and bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from controller.bench.gestures import save_clause
from controller.commands.gestures import GESTURE_LABELS, GesturePlayer
from hw import g1
from tests.conftest import g1ctl, one_line_error

FPS = 30.0


def _held(gesture: str, seconds: float = 3.0) -> np.ndarray:
    """The G1 standing with the procedural gesture `gesture` fully blended in (standing still for "none")."""
    unbounded = np.full(g1.NUM_JOINTS, 10.0)
    player = GesturePlayer(g1.JOINT_NAMES, -unbounded, unbounded)
    frames = np.tile(np.asarray(g1.standing_qpos()), (round(seconds * FPS), 1))
    for k in range(len(frames)):
        frames[k, g1.QPOS_JOINTS] = player.apply(np.asarray(g1.default_joint_vector()), GESTURE_LABELS.index(gesture), 1.0, k / FPS)
    return frames


def test_bench_scores_executed_clauses(tmp_path: Path) -> None:
    clauses = tmp_path / "clauses"
    clauses.mkdir()
    save_clause(clauses / "a.npz", _held("point"), FPS, ["point"], "point for three seconds")
    save_clause(clauses / "b.npz", _held("none"), FPS, [], "stand still for three seconds")
    save_clause(clauses / "c.npz", _held("reach"), FPS, ["arms_crossed"], "cross your arms (the robot reached instead)")
    report_path = tmp_path / "bench.json"
    result = g1ctl("bench", "gestures", "--data", str(clauses), "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["samples"] == 3 and report["data"] == {str(clauses): 3}
    assert report["per_name"]["point"] == {"asked": 1, "recall": 1.0, "precision": 1.0, "false_positives": 0}
    assert report["per_name"]["arms_crossed"]["recall"] == 0.0 and report["per_name"]["reach"]["false_positives"] == 1
    assert report["wrong"] == [
        {"source": "clauses/c: cross your arms (the robot reached instead)", "asked": ["arms_crossed"], "detected": ["reach"]}
    ]
    assert "arms_crossed" in result.stdout and "wrong: clauses/c" in result.stdout


def test_bench_needs_data() -> None:
    assert "--data PATH" in one_line_error(g1ctl("bench", "gestures"))


def test_bench_names_a_folder_it_cannot_read(tmp_path: Path) -> None:
    line = one_line_error(g1ctl("bench", "gestures", "--data", str(tmp_path / "absent")))
    assert str(tmp_path / "absent") in line and "no such folder" in line
    line = one_line_error(g1ctl("bench", "gestures", "--data", str(tmp_path)))
    assert str(tmp_path) in line and "neither a recorded dataset" in line
