"""Real-time scheduling requests: range checked, normal scheduling kept on 0."""

from __future__ import annotations

import os

import pytest

from hw.errors import ConfigError
from hw.realtime import Scheduling, request_realtime


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
