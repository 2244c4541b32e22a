"""The executor: a task whose worker dies is retried once, then reported lost; the others are not touched."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from controller.eval.executor import Executor, TaskLost


def test_this_process_runs_tasks_in_order() -> None:
    with Executor(1) as executor:
        assert list(executor.map_unordered(lambda x: x * 2, [(1,), (2,), (3,)])) == [(0, 2), (1, 4), (2, 6)]


@pytest.mark.slow  # starts a local Ray instance
def test_a_dead_worker_loses_only_its_task_retried_once_first(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason="the eval extra (ray) is not installed")

    def task(kind: str, marker: str) -> str:  # nested: Ray ships it by value
        if kind == "dies-always":
            os._exit(1)  # the worker process dies, as on a segfault or an OOM kill
        if kind == "dies-once" and not Path(marker).exists():
            Path(marker).touch()
            os._exit(1)
        return kind

    marker = str(tmp_path / "died-once")
    items = [("fine", marker), ("dies-always", marker), ("dies-once", marker), ("fine", marker)]
    with Executor(2) as executor:
        results = dict(executor.map_unordered(task, items))
    assert results[0] == results[3] == "fine" and results[2] == "dies-once"  # the retry ran it again
    assert isinstance(results[1], TaskLost) and "Worker" in str(results[1])
    assert len(results) == 4  # nothing dropped
