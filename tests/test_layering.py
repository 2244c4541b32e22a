"""Package layering from DESIGN.md, enforced by folder.

Two kinds of check: an AST scan of every import statement (lazy ones inside functions
included) says what a file imports directly; a subprocess that imports every module of a
folder says what it pulls in transitively (`sys.modules`). Modules are found by walking the
folders, so a new module is covered without editing this file.
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

import pytest

from tests.conftest import ROOT

PACKAGES = ("controller", "hw", "sim")

# Where mujoco may be imported directly: the simulator, and the controller folders that drive it.
MUJOCO_FOLDERS = ("sim", "controller/motion_data", "controller/bench")
TORCH_FOLDERS = ("controller/training",)

# The hardware run path: what `g1ctl hw ...` and a hardware session load.
HARDWARE_PATH_MODULES = (
    "controller.runtime.hardware",
    "controller.runtime.loop",
    "controller.runtime.supervisor",
    "controller.cli.main",
    "controller.cli.hw",
)
# Folders whose every module must load without mujoco or torch (reference: where it exists).
SIM_FREE_FOLDERS = ("controller/tracking", "controller/reference", "controller/inputs", "controller/planner", "controller/text")

# Host-side driver modules the firmware emulators must not use: an emulator stands for the motor's
# own firmware, so it may share the pure protocol codecs, never the host's drivers.
HOST_DRIVER_MODULES = ("hw.drivers", "hw.hardware_robot", "hw.imu", "hw.feedback", "hw.transport", "hw.safety", "hw.bringup")

# `controller/` keeps its code in role folders; only these modules sit at its top level.
CONTROLLER_TOP_LEVEL = {"__init__", "assets", "reports", "onnx_session"}


def python_files(folder: str) -> list[Path]:
    return sorted((ROOT / folder).rglob("*.py"))


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules_under(*folders: str) -> list[str]:
    """Every importable module of the folders (a `__main__` runs a command when imported: left out)."""
    return [module_name(p) for folder in folders for p in python_files(folder) if p.stem != "__main__"]


def imported_modules(path: Path) -> set[str]:
    """Dotted names a file imports directly; `from a import b` gives `a` and `a.b` (b may be a module)."""
    package = module_name(path).split(".")
    if path.stem != "__init__":
        package = package[:-1]
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = ".".join([*package[: len(package) - node.level + 1], node.module or ""]).strip(".") if node.level else node.module
            if base:
                names.add(base)
                names |= {f"{base}.{alias.name}" for alias in node.names if alias.name != "*"}
    return names


def matches(name: str, prefixes: Iterable[str]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def direct_imports_of(forbidden: tuple[str, ...], folders: Iterable[str], allowed_in: tuple[str, ...] = ()) -> dict[str, list[str]]:
    """File -> the forbidden modules it imports, for the files of `folders` outside `allowed_in`."""
    found = {}
    for folder in folders:
        for path in python_files(folder):
            rel = path.relative_to(ROOT).as_posix()
            if any(rel.startswith(a + "/") for a in allowed_in):
                continue
            hits = sorted(n for n in imported_modules(path) if matches(n, forbidden))
            if hits:
                found[rel] = hits
    return found


_LOADED = """
import importlib, json, sys
forbidden = sys.argv[1].split(",")
first_seen = {}
for name in sys.argv[2:]:
    importlib.import_module(name)
    for f in forbidden:
        if f in sys.modules and f not in first_seen:
            first_seen[f] = name
print(json.dumps(first_seen))
"""


def loaded_by(modules: list[str], forbidden: tuple[str, ...]) -> dict[str, str]:
    """Forbidden top-level modules found in `sys.modules` after importing `modules` in a fresh
    interpreter, each with the module whose import brought it in."""
    assert modules
    result = subprocess.run(
        [sys.executable, "-c", _LOADED, ",".join(forbidden), *modules], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert result.returncode == 0, result.stderr
    return dict(json.loads(result.stdout.strip().splitlines()[-1]))


def test_the_folder_walk_finds_modules() -> None:
    assert "hw.protocols.mit" in modules_under("hw")
    assert "controller.cli" in modules_under("controller/cli")
    assert "controller.cli.__main__" not in modules_under("controller/cli")
    assert imported_modules(ROOT / "controller/inputs/base.py") >= {"abc", "dataclasses.dataclass"}


def test_torch_is_imported_only_by_the_trainer() -> None:
    assert direct_imports_of(("torch",), PACKAGES, allowed_in=TORCH_FOLDERS) == {}


def test_mujoco_is_imported_only_by_the_simulator_and_what_drives_it() -> None:
    assert direct_imports_of(("mujoco",), PACKAGES, allowed_in=MUJOCO_FOLDERS) == {}


def test_hw_imports_neither_controller_nor_sim_nor_mujoco_nor_torch() -> None:
    assert direct_imports_of(("controller", "sim", "mujoco", "torch"), ("hw",)) == {}


def test_hw_loads_none_of_controller_sim_mujoco_torch() -> None:
    assert loaded_by(modules_under("hw"), ("controller", "sim", "mujoco", "torch")) == {}


def test_hardware_run_path_trackers_reference_inputs_and_planner_load_neither_mujoco_nor_torch() -> None:
    folders = [f for f in SIM_FREE_FOLDERS if (ROOT / f).is_dir()]
    modules = [*HARDWARE_PATH_MODULES, *modules_under(*folders)]
    assert "controller.planner.runtime" in modules and "controller.inputs.gamepad" in modules
    assert loaded_by(modules, ("mujoco", "torch")) == {}


def test_firmware_emulators_use_no_host_driver() -> None:
    assert direct_imports_of(HOST_DRIVER_MODULES, ("hw/emulation",)) == {}
    loaded = loaded_by(modules_under("hw/emulation"), HOST_DRIVER_MODULES)
    assert loaded == {}, f"host driver modules loaded by the emulators (driver module: first emulator module importing it): {loaded}"


def test_controller_top_level_keeps_few_modules() -> None:
    top = {p.stem for p in (ROOT / "controller").glob("*.py")}
    assert top <= CONTROLLER_TOP_LEVEL, f"new top-level modules {sorted(top - CONTROLLER_TOP_LEVEL)}: put them in a role folder"


def test_no_test_module_imports_from_another_test_module() -> None:
    """Helpers shared between test modules live in tests/conftest.py."""
    found = {}
    for path in sorted((ROOT / "tests").rglob("*.py")):
        others = {n for n in imported_modules(path) if matches(n, ("tests",)) and not matches(n, ("tests.conftest",))}
        # `from tests import conftest` names the package and the helper module: both are fine.
        others -= {"tests", "tests.conftest"}
        if others:
            found[path.relative_to(ROOT).as_posix()] = sorted(others)
    assert found == {}


_SIDE_EFFECTS = """
import importlib, json, os, sys
env = dict(os.environ)
import matplotlib
backend = dict.__getitem__(matplotlib.rcParams, "backend")
for name in sys.argv[1:]:
    importlib.import_module(name)
changed = sorted(k for k in set(env) | set(os.environ) if env.get(k) != os.environ.get(k))
print(json.dumps({"env": changed, "backend_changed": dict.__getitem__(matplotlib.rcParams, "backend") != backend}))
"""


def torch_modules() -> list[str]:
    """The modules that import torch themselves: they load only where the train extra is installed."""
    return sorted(module_name(ROOT / f) for f in direct_imports_of(("torch",), PACKAGES))


def global_state_changed_by(modules: list[str]) -> dict[str, object]:
    """What importing `modules` in a fresh interpreter changed: environment variables, matplotlib's backend.
    The display variables are removed first, so that a module that would set a headless default has a reason to."""
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY", "MPLBACKEND")}
    result = subprocess.run([sys.executable, "-c", _SIDE_EFFECTS, *modules], capture_output=True, text=True, cwd=ROOT, env=env, timeout=180)
    assert result.returncode == 0, result.stderr
    return dict(json.loads(result.stdout.strip().splitlines()[-1]))


@pytest.mark.slow
def test_importing_any_module_changes_no_global_state() -> None:
    """No environment variable set and no matplotlib backend chosen on import: that is for the
    function that renders or draws. The trainer's torch modules are checked by the next test."""
    torch = torch_modules()
    assert "controller.training.planner" in torch
    modules = [m for m in modules_under(*PACKAGES) if m not in torch]
    assert global_state_changed_by(modules) == {"env": [], "backend_changed": False}


@pytest.mark.train
def test_importing_the_trainer_changes_no_global_state() -> None:
    pytest.importorskip("torch", reason="the train extra (torch) is not installed")
    assert global_state_changed_by(torch_modules()) == {"env": [], "backend_changed": False}
