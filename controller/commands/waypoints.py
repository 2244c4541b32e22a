"""World-frame waypoints: the root poses a scenario or a text program sends the robot to, in order."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class WorldWaypoint:
    """A root pose to go to: position (m, world frame) and heading (degrees, counter-clockwise from +x)."""

    x: float
    y: float
    heading_deg: float = 0.0

    def __post_init__(self) -> None:
        for name in ("x", "y", "heading_deg"):  # a NaN target is never reached and an infinite one runs the policy off
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"waypoint {name} is {getattr(self, name)}: give finite numbers (x, y in m, heading_deg in degrees)")
