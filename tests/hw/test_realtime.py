"""Real-time scheduling requests: range checked, normal scheduling kept on 0."""

from __future__ import annotations

import os
import threading

import pytest

from hw.errors import ConfigError
from hw.realtime import Scheduling, last_cpu, pin_to_cpu, request_realtime


def test_priority_zero_keeps_normal_scheduling() -> None:
    before = os.sched_getscheduler(0)
    assert request_realtime(0) == Scheduling("SCHED_OTHER", 0)
    assert os.sched_getscheduler(0) == before


@pytest.mark.parametrize("priority", [-1, 100])
def test_out_of_range_priority_is_a_config_error(priority: int) -> None:
    with pytest.raises(ConfigError, match="use 1-99"):
        request_realtime(priority)


def test_description_names_policy_priority_and_reason() -> None:
    assert Scheduling("SCHED_FIFO", 50).describe() == "SCHED_FIFO 50"
    assert Scheduling("SCHED_OTHER", 0, "not permitted").describe() == "SCHED_OTHER (not permitted)"
    assert Scheduling("SCHED_FIFO", 50, cpu=1).describe() == "SCHED_FIFO 50, pinned to CPU 1"


def test_cpu_that_is_not_available_is_named() -> None:
    with pytest.raises(ConfigError, match="CPU 4096 is not available to this process: use one of"):
        request_realtime(0, cpu=4096)


def test_pinning_holds_for_the_thread_and_the_threads_it_starts() -> None:
    """Pinned inside a helper thread, so the test process itself stays free."""
    seen: dict[str, set[int]] = {}

    def child() -> None:
        seen["child"] = os.sched_getaffinity(0)

    def pinned() -> None:
        pin_to_cpu(last_cpu())
        seen["thread"] = os.sched_getaffinity(0)
        t = threading.Thread(target=child)
        t.start()
        t.join()

    outer = threading.Thread(target=pinned)
    outer.start()
    outer.join()
    assert seen == {"thread": {last_cpu()}, "child": {last_cpu()}}
    assert os.sched_getaffinity(0) != {last_cpu()} or os.cpu_count() == 1
