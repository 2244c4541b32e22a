"""`g1ctl viz plan` with the shipped planner: a target out of reach is said, a target that is not finite is refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from hw.shipped import model_dir
from tests.conftest import g1ctl, one_line_error

pytestmark = pytest.mark.skipif(not (model_dir("planner") / "planner.onnx").is_file(), reason="no shipped planner model")


@pytest.mark.slow
def test_a_target_out_of_reach_is_drawn_with_a_warning(tmp_path: Path) -> None:
    out = tmp_path / "far.png"
    result = g1ctl("viz", "plan", "--out", str(out), "--target", "10,0,0", "--seeds", "1")
    assert result.returncode == 0, result.stderr
    assert out.is_file()
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning: ")]
    assert len(warnings) == 1 and "frame 43 is 10.00 m from the context's root" in warnings[0]
    near = g1ctl("viz", "plan", "--out", str(out), "--target", "1,0,0", "--seeds", "1")
    assert near.returncode == 0 and "warning" not in near.stderr


def test_a_target_that_is_not_finite_is_one_line(tmp_path: Path) -> None:
    line = one_line_error(g1ctl("viz", "plan", "--out", str(tmp_path / "x.png"), "--target", "nan,0,0"))
    assert "keyframe at frame 43: root x is nan" in line
