"""Styles by clip name: the folder an import came from, or a glob."""

from __future__ import annotations

import pytest

from controller.motion_data import styles
from hw.errors import ConfigError

NAMES = ["bonus-B_Fence1", "bonus-B_HandsUp", "dance-B_DadDance", "dance-J_Dance2_Salsa", "walk3"]


def test_a_folder_or_a_glob_names_a_style() -> None:
    assert [n for n in NAMES if styles.matches(n, ("bonus",))] == ["bonus-B_Fence1", "bonus-B_HandsUp"]
    assert [n for n in NAMES if styles.matches(n, ("dance-B_*", "walk3"))] == ["dance-B_DadDance", "walk3"]
    assert not styles.matches("bonusX-clip", ("bonus",))  # a folder is matched whole
    assert styles.unmatched(NAMES, ("bonus", "jazz")) == ["jazz"]
    assert styles.folder_prefixes(NAMES) == ["bonus", "dance", "walk3"]


def test_patterns_are_parsed_or_named() -> None:
    assert styles.parse_patterns(" bonus, dance-B_*,bonus", "--hold-out") == ("bonus", "dance-B_*")
    with pytest.raises(ConfigError, match="--only needs clip name patterns"):
        styles.parse_patterns(" , ", "--only")
