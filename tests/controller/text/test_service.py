"""The text planner's service: the text slot is refused, not skipped, when the shipped planner has none."""

from __future__ import annotations

import json

import pytest

from controller.text.service import TextPlanner
from hw.errors import ConfigError
from hw.shipped import model_dir


def test_asking_for_the_text_slot_of_a_planner_trained_without_text_is_refused() -> None:
    if json.loads((model_dir("planner") / "planner.json").read_text()).get("text_conditioned"):
        pytest.skip("the shipped planner has a text slot")
    planner = TextPlanner(encoder=None, condition_text=True)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="trained without text"):
        planner.text_embedding()
    assert TextPlanner(encoder=None).text_embedding() is None  # type: ignore[arg-type]  # not asked: none
