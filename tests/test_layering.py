"""Package layering from DESIGN.md: hw imports nothing of controller/sim; the controller's
hardware path runs without MuJoCo."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def imported_roots(path: Path) -> set[str]:
    roots = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            roots |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            roots.add(node.module.split(".")[0])
    return roots


def test_hw_imports_neither_controller_nor_sim_nor_mujoco() -> None:
    for path in (ROOT / "hw").rglob("*.py"):
        assert not imported_roots(path) & {"controller", "sim", "mujoco"}, path


def test_controller_hardware_path_and_planner_runtime_do_not_import_mujoco() -> None:
    code = (
        "import sys; import controller.tracking.velocity_policy, controller.runtime.loop, controller.runtime.supervisor, controller.cli.main, "
        "controller.inputs.gamepad, controller.inputs.keyboard, controller.inputs.scripted, controller.assets, "
        "controller.planner.runtime, controller.motion_data.dataset, controller.bench.baselines, controller.bench.motion_metrics; "
        "print('mujoco' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert out.stdout.strip() == "False"
