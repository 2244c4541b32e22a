"""The firmware emulators stand where the motors would: they share the wire protocols and the
joint map with the host, never its drivers, so that a host bug cannot hide behind an emulator
that runs the same code."""

from __future__ import annotations

import ast
from pathlib import Path

EMULATION = Path(__file__).resolve().parents[2] / "hw" / "emulation"
SHARED = ("hw.emulation", "hw.protocols", "hw.types", "hw.jointmap", "hw.errors", "hw.g1", "hw.yamlconfig")


def _hw_imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names if alias.name.split(".")[0] == "hw"}
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "hw":
            found |= {node.module} if node.module != "hw" else {f"hw.{alias.name}" for alias in node.names}
    return found


def test_emulators_import_no_host_side_module() -> None:
    paths = sorted(EMULATION.glob("*.py"))
    assert paths
    for path in paths:
        host_side = {m for m in _hw_imports(path) if not any(m == s or m.startswith(f"{s}.") for s in SHARED)}
        assert not host_side, f"{path.name} imports host-side {sorted(host_side)}; share the piece through {SHARED}"
