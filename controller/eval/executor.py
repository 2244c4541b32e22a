"""Where independent tasks run: this process, a local Ray instance started for the command, or a Ray cluster.

`Executor(workers, address)` is a context manager; `map_unordered(fn, items)` yields
`(index, result)` as tasks finish, or `(index, error)` for a task whose worker died twice
(Ray retries it once). Results never depend on the executor: every task carries its own seed.
With `workers == 1` and no address nothing but this process is used (and Ray need not be installed).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator, Sequence
from types import TracebackType
from typing import Any, Self

from hw.errors import ConfigError

RAY_HINT = "--workers > 1 and --address need Ray: pip install -e '.[eval]' (or run with --workers 1)"
# A task is one episode on one CPU: its numerical libraries get one thread each. OpenBLAS otherwise starts a
# thread per core in every worker, and on a 2-core machine two workers' idle threads spin against each other.
SINGLE_THREADED = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


class TaskLost(Exception):
    """A task's worker died on both tries: its result is lost, and says so."""


class Executor:
    def __init__(self, workers: int = 1, address: str | None = None) -> None:
        if workers < 1:
            raise ConfigError(f"--workers must be at least 1, got {workers}")
        self.workers, self.address = workers, address
        self._ray: Any = None
        self._started = False

    @property
    def in_process(self) -> bool:
        return self.workers == 1 and self.address is None

    def __enter__(self) -> Self:
        if self.in_process:
            return self
        try:
            import ray  # noqa: PLC0415 - the eval extra
        except ImportError as exc:
            raise ConfigError(RAY_HINT) from exc
        self._ray = ray
        if not ray.is_initialized():
            quiet: dict[str, Any] = {"log_to_driver": False, "logging_level": logging.WARNING, "runtime_env": {"env_vars": SINGLE_THREADED}}
            if self.address is not None:
                ray.init(address=self.address, **quiet)
            else:
                ray.init(num_cpus=self.workers, include_dashboard=False, **quiet)
            self._started = True
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        if self._started:
            self._ray.shutdown()
            self._started = False

    def map_unordered(
        self, fn: Callable[..., Any], items: Sequence[tuple[Any, ...]], cpus: Sequence[int] | None = None
    ) -> Iterator[tuple[int, Any]]:
        """`fn(*item)` for every item; `(index, result)` as each finishes (in order in this process).

        `cpus`: CPUs each task holds while it runs (default 1; on a local instance at most `workers`).
        """
        if self.in_process:
            for index, item in enumerate(items):
                yield index, fn(*item)
            return
        ray = self._ray
        task = ray.remote(num_cpus=1, max_retries=1)(fn)
        needs = [min(c, self.workers) if self.address is None else c for c in (cpus or [1] * len(items))]
        pending = {
            (task.options(num_cpus=n) if n != 1 else task).remote(*item): index
            for index, (item, n) in enumerate(zip(items, needs, strict=True))
        }
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                index = pending.pop(ref)
                try:
                    yield index, ray.get(ref)
                except ray.exceptions.RayError as exc:
                    yield index, TaskLost(f"{type(exc).__name__}: {str(exc).splitlines()[0]}")
