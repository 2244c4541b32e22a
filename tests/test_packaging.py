"""The wheel built from the working tree holds every package and shipped file, and once
installed in a fresh virtual environment (without the train extra) `g1ctl sim` walks from
a folder outside the repository, importing nothing from it.

The wheel is built from a copy of the working tree's files (tracked, and untracked but not
ignored), so that the build neither writes `build/` or `*.egg-info` into the shared checkout
nor packs a stale module left in `build/lib` by an earlier build.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest

from controller.assets import Assets
from tests.conftest import ROOT

CODE = ("controller", "hw", "sim")
DATA = {"configs": "g1ctl_data/configs", "models": "g1ctl_data/models"}  # source folder -> where the wheel puts it
PLANNER_FILES = ("models/planner/planner.onnx", "models/planner/planner.json")
# What the commands below may take: building installs the build backend pyproject.toml asks for into an
# isolated environment, as `pip install .` does for a user (the venv's own setuptools may be too old to
# build a wheel); installing pulls the dependencies from the configured package index.
BUILD_TIMEOUT_S, INSTALL_TIMEOUT_S = 300, 900


def working_tree_files() -> list[Path]:
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"], capture_output=True, text=True, cwd=ROOT, check=True
    ).stdout
    return [Path(p) for p in listed.split("\0") if p and (ROOT / p).is_file()]  # a deleted file stays listed until committed


def source_packages() -> list[str]:
    """Every folder with an `__init__.py` under the code packages, as a dotted name."""
    return sorted(".".join(p.parent.relative_to(ROOT).parts) for top in CODE for p in (ROOT / top).rglob("__init__.py"))


def expected_wheel_paths() -> set[str]:
    """Every module of the code packages, every YAML config, and the planner's model files, as wheel paths."""
    modules = {p.relative_to(ROOT).as_posix() for top in CODE for p in (ROOT / top).rglob("*.py")}
    configs = {DATA["configs"] + "/" + p.relative_to(ROOT / "configs").as_posix() for p in (ROOT / "configs").rglob("*.yaml")}
    planner = {DATA["models"] + "/" + Path(p).relative_to("models").as_posix() for p in PLANNER_FILES}
    return modules | configs | planner


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    src, dist = tmp_path_factory.mktemp("src"), tmp_path_factory.mktemp("dist")
    for rel in working_tree_files():
        (src / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / rel, src / rel)
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(dist), str(src)],
        capture_output=True,
        text=True,
        timeout=BUILD_TIMEOUT_S,
    )
    assert build.returncode == 0, build.stdout + build.stderr
    (built,) = dist.glob("g1ctl-*.whl")
    return built


def test_the_source_walk_finds_the_packages() -> None:
    packages = source_packages()
    assert {"controller", "controller.cli", "controller.planner", "hw", "hw.protocols", "sim"} <= set(packages)
    assert all((ROOT / f).is_file() for f in PLANNER_FILES)


@pytest.mark.slow
def test_wheel_holds_every_package_module_config_and_the_planner(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    missing_packages = [p for p in source_packages() if p.replace(".", "/") + "/__init__.py" not in names]
    assert missing_packages == [], (
        f"packages missing from the wheel: add them to [tool.setuptools] packages in pyproject.toml: {missing_packages}"
    )
    assert sorted(expected_wheel_paths() - names) == []
    assert not any(n.startswith("tests/") for n in names)
    entry_points = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    assert "g1ctl = controller.cli.main:main" in zipfile.ZipFile(wheel).read(entry_points).decode()


def run(cmd: list[str | Path], cwd: Path, env: dict[str, str], timeout: float) -> subprocess.CompletedProcess[str]:
    result = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, cwd=cwd, env=env, timeout=timeout)
    assert result.returncode == 0, f"{cmd} failed:\n{result.stdout}\n{result.stderr}"
    return result


@pytest.mark.slow
def test_installed_wheel_walks_from_outside_the_repository(wheel: Path, tmp_path: Path, assets: Assets) -> None:
    """A fresh venv (no train extra, so no torch), the wheel installed with its dependencies,
    and a five-second walk from an empty folder, with the assets already fetched."""
    venv, cwd = tmp_path / "venv", tmp_path / "elsewhere"
    cwd.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env["G1CTL_ASSETS_DIR"] = str(assets.root)
    python, g1ctl = venv / "bin" / "python", venv / "bin" / "g1ctl"

    started = time.monotonic()
    run([sys.executable, "-m", "venv", venv], cwd, env, 120)
    run([python, "-m", "pip", "install", "--quiet", wheel], cwd, env, INSTALL_TIMEOUT_S)
    installed_in = time.monotonic() - started
    print(f"fresh venv with the wheel and its dependencies: {installed_in:.1f} s")

    where = run(
        [python, "-c", "import controller, hw, sim, importlib.util as u; print(controller.__file__, u.find_spec('torch'))"], cwd, env, 60
    )
    controller_file, torch_spec = where.stdout.split()
    assert Path(controller_file).is_relative_to(venv), f"controller imported from {controller_file}, not the venv"
    assert torch_spec == "None", "torch is installed without the train extra"

    result = run([g1ctl, "sim", "--scenario", "walk_turn_stop", "--duration", "5", "--report", "R.json"], cwd, env, 300)
    report = json.loads((cwd / "R.json").read_text())
    assert report["falls"] == 0, (report, result.stderr)
