"""The README's Python example runs as written (what the README says, a command shows)."""

from __future__ import annotations

import re

from tests.conftest import ROOT


def test_readme_planner_example_runs() -> None:
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    assert blocks, "the README lost its Python example"
    for block in blocks:
        namespace: dict[str, object] = {}
        exec(compile(block, "README.md", "exec"), namespace)
        plan = namespace["plan"]
        assert plan.qpos.shape == (44, 36) and plan.contacts.shape == (44, 2)  # type: ignore[attr-defined]
