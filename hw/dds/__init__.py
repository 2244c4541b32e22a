"""The G1's low-level DDS interface (`rt/lowcmd`, `rt/lowstate`) on Cyclone DDS: the `g1` extra."""

from __future__ import annotations

import importlib.util

from hw.errors import ConfigError

EXTRA_HINT = "the G1 DDS backend needs cyclonedds: pip install -e '.[g1]' (on the robot's aarch64 computer it builds from source)"


def require_cyclonedds() -> None:
    """One clear line naming the extra when cyclonedds is missing."""
    if importlib.util.find_spec("cyclonedds") is None:
        raise ConfigError(EXTRA_HINT)
