"""Package layering (docs/design.md, "Packages and their layering"), enforced by folder.

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
MUJOCO_FOLDERS = ("sim", "controller/bench")
TORCH_FOLDERS = ("controller/training",)

# The hardware run path: what `g1ctl hw ...` and a hardware session load (a run on a real robot: the driver, the plan of
# the run, the backend registry, the DDS backends and the backends of robots on buses; its recording included).
HARDWARE_PATH_MODULES = (
    "controller.runtime.bench_robot",
    "controller.runtime.bringup",
    "controller.runtime.loop",
    "controller.runtime.supervisor",
    "controller.runtime.driver",
    "controller.runtime.run_plan",
    "controller.runtime.backend_registry",
    "controller.runtime.dds_backend",
    "controller.runtime.hardware_backend",
    "controller.cli.main",
    "controller.cli.hw",
    "controller.runtime.session",
    "controller.recording.recorder",  # `--record` on a robot's run: the loop's side, its writer thread, the topics
)
# Folders whose every module must load without mujoco or torch (reference: where it exists).
SIM_FREE_FOLDERS = (
    "controller/commands",
    "controller/tracking",
    "controller/reference",
    "controller/inputs",
    "controller/planner",
    "controller/text",
    "controller/estimation",
)

# Host-side driver modules the firmware emulators must not use: an emulator stands for the motor's
# own firmware, so it may share the pure protocol codecs, never the host's drivers.
HOST_DRIVER_MODULES = (
    "hw.drivers", "hw.hardware_robot", "hw.imu", "hw.feedback", "hw.transport", "hw.slcan", "hw.safety", "hw.bench", "hw.bus_bench",
)  # fmt: skip

# `controller/` keeps its code in role folders; only these modules sit at its top level.
CONTROLLER_TOP_LEVEL = {"__init__", "assets", "reports", "onnx_session"}

# The layer order of controller/, lowest first: a folder imports from folders of lower layers only, never
# from its own layer's other folders nor from above. The top-level modules are the ground floor.
CONTROLLER_LAYERS: tuple[tuple[str, ...], ...] = (
    ("assets", "reports", "onnx_session"),  # controller/'s top-level modules
    ("commands", "planner", "estimation"),  # the command vocabulary; the planner contract and its runtime; the state estimator
    ("inputs", "motion_data", "reference"),  # command sources; the motion dataset; what a tracker follows
    ("tracking", "recording"),  # trackers: reference window in, joint command out; the flight recorder and its readers
    ("runtime",),  # sessions, backends, whole sim and robot runs
    ("eval", "text"),  # applications that drive runs: suites and the dataset recorder; prompts run as programs
    ("training",),
    ("bench",),
    ("cli",),
)

# Names that once meant two things in different modules (issue 20): each stays defined by one module at most.
SPLIT_NAMES = ("Waypoint", "Episode", "GESTURES", "ROOT_BODY", "GRAVITY", "_LEGS", "_ARMS", "_LEFT_ARM")


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


# An import between two parts of controller/: (importing file, its part, the imported part, the imported module).
ControllerImport = tuple[str, str, str, str]


def controller_part(name: str) -> str | None:
    """The role folder (or top-level module) of controller/ that a dotted name is in; None outside it."""
    parts = name.split(".")
    return parts[1] if parts[0] == "controller" and len(parts) > 1 else None


def controller_imports() -> list[ControllerImport]:
    """Every import of one part of controller/ by another, one per file and imported part (the module it names)."""
    found: dict[tuple[str, str], ControllerImport] = {}
    for path in python_files("controller"):
        here = controller_part(module_name(path))
        rel = path.relative_to(ROOT).as_posix()
        for name in sorted(imported_modules(path), key=len):
            there = controller_part(name)
            if here is not None and there is not None and there != here:
                found.setdefault((rel, there), (rel, here, there, name))
    return sorted(found.values())


def layer_violations(imports: Iterable[ControllerImport]) -> list[str]:
    """The imports against CONTROLLER_LAYERS, each named with its file."""
    layer = {part: i for i, parts in enumerate(CONTROLLER_LAYERS) for part in parts}
    return [
        f"{file} imports {name}: {here} (layer {layer.get(here)}) may import only from layers below it, {there} is layer {layer.get(there)}"
        for file, here, there, name in imports
        if here not in layer or there not in layer or layer[there] >= layer[here]
    ]


def import_cycles(imports: Iterable[ControllerImport]) -> list[str]:
    """Groups of controller/ parts that import each other round a cycle, each folder import in them named by one file."""
    first: dict[tuple[str, str], str] = {}
    for file, here, there, name in imports:
        first.setdefault((here, there), f"{file} imports {name}")
    edges: dict[str, set[str]] = {}
    for here, there in first:
        edges.setdefault(here, set()).add(there)

    def reachable(start: str) -> set[str]:
        seen: set[str] = set()
        todo = [start]
        while todo:
            for nxt in edges.get(todo.pop(), ()):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        return seen

    reach = {part: reachable(part) for part in edges}
    groups = {frozenset(m for m in reach if m in reach[part] and part in reach[m]) for part in reach if part in reach[part]}
    return [
        ", ".join(sorted(group))
        + ": "
        + "; ".join(f"{here} -> {there} ({why})" for (here, there), why in sorted(first.items()) if here in group and there in group)
        for group in sorted(groups, key=sorted)
    ]


def top_level_definitions(folders: Iterable[str]) -> dict[str, list[str]]:
    """Name -> the files that define it at module level (class, function or assignment)."""
    found: dict[str, list[str]] = {}
    for folder in folders:
        for path in python_files(folder):
            for node in ast.parse(path.read_text(), str(path)).body:
                if isinstance(node, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
                    names = [node.name]
                elif isinstance(node, ast.Assign | ast.AnnAssign):
                    targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                    names = [n.id for t in targets for n in (t.elts if isinstance(t, ast.Tuple) else [t]) if isinstance(n, ast.Name)]
                else:
                    continue
                for name in names:
                    found.setdefault(name, []).append(path.relative_to(ROOT).as_posix())
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


def test_every_controller_folder_has_a_layer() -> None:
    parts = {p.name for p in (ROOT / "controller").iterdir() if p.is_dir() and any(p.glob("*.py"))}
    parts |= {p.stem for p in (ROOT / "controller").glob("*.py")} - {"__init__"}
    layered = [part for layer in CONTROLLER_LAYERS for part in layer]
    assert len(layered) == len(set(layered)), f"a part is in two layers: {sorted(p for p in layered if layered.count(p) > 1)}"
    assert parts == set(layered), (
        f"give {sorted(parts - set(layered))} a layer in CONTROLLER_LAYERS; {sorted(set(layered) - parts)} are gone"
    )


def test_the_layer_checks_name_the_imports_that_break_them() -> None:
    """The cycle between inputs and motion_data that the command vocabulary removed, as the checks report it."""
    before = [
        ("controller/inputs/scripted.py", "inputs", "motion_data", "controller.motion_data.dataset"),
        ("controller/motion_data/command_programs.py", "motion_data", "inputs", "controller.inputs.base"),
        ("controller/tracking/tracker.py", "tracking", "reference", "controller.reference.window"),
    ]
    violations = layer_violations(before)
    assert len(violations) == 2
    assert violations[0].startswith("controller/inputs/scripted.py imports controller.motion_data.dataset: inputs (layer 2)")
    assert import_cycles(before) == [
        "inputs, motion_data: inputs -> motion_data (controller/inputs/scripted.py imports controller.motion_data.dataset); "
        "motion_data -> inputs (controller/motion_data/command_programs.py imports controller.inputs.base)"
    ]


def test_controller_folders_import_only_from_lower_layers() -> None:
    imports = controller_imports()
    assert ("controller/tracking/tracker.py", "tracking", "reference", "controller.reference.window") in imports
    violations = layer_violations(imports)
    assert not violations, "imports against CONTROLLER_LAYERS:\n" + "\n".join(violations)


def test_no_import_cycle_between_controller_folders() -> None:
    cycles = import_cycles(controller_imports())
    assert not cycles, "controller/ folders importing each other round a cycle:\n" + "\n".join(cycles)


def test_names_that_meant_two_things_stay_split() -> None:
    """A generic check cannot tell a restated name (FloatArray, each CLI module's `run`) from one with two
    meanings, so only the names that were split are held to one defining module."""
    definitions = top_level_definitions(PACKAGES)
    assert "hw/g1.py" in definitions["ROOT_BODY"] and "controller/planner/encoding.py" in definitions["_LEGS"]  # tuple targets too
    doubled = {name: definitions[name] for name in SPLIT_NAMES if len(definitions.get(name, [])) > 1}
    assert doubled == {}, f"defined by more than one module, with different meanings before: {doubled}"


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
