"""World-frame waypoints: the root poses a scenario or a text program sends the robot to, in order."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class WorldWaypoint:
    """A root pose to go to: position (m, world frame) and heading (degrees, counter-clockwise from +x)."""

    x: float
    y: float
    heading_deg: float = 0.0
