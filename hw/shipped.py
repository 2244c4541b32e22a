"""Where the shipped configs and models are: package data, found through the import system.

`configs/` and `models/` are installed as the data packages `g1ctl_data.configs` and
`g1ctl_data.models` (see `pyproject.toml`), so an installed `g1ctl` finds them wherever it
runs, and an editable install finds the source tree's folders through the same lookup.
"""

from __future__ import annotations

import functools
import importlib.util
from pathlib import Path

from hw.errors import AssetError

DATA_PACKAGE = "g1ctl_data"


@functools.cache
def _data_dir(kind: str) -> Path:
    spec = importlib.util.find_spec(f"{DATA_PACKAGE}.{kind}")
    # An editable install lists a path-hook entry beside the real folder: take the folder.
    for location in (spec.submodule_search_locations or []) if spec else []:
        if Path(location).is_dir():
            return Path(location)
    raise AssetError(f"the shipped {kind} are not installed ({DATA_PACKAGE}.{kind} not found); reinstall g1ctl ('pip install .')")


def config_dir(*parts: str) -> Path:
    """A folder of shipped YAML configs, e.g. `config_dir("policies")`."""
    return _data_dir("configs").joinpath(*parts)


def model_dir(*parts: str) -> Path:
    """A folder of shipped models, e.g. `model_dir("planner")`."""
    return _data_dir("models").joinpath(*parts)
