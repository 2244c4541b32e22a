"""The reference window: what a tracker is asked to follow at one tick.

Every tracker reads the same value, so the session never needs to know which tracker
runs. Today the reference is the supervised velocity command (the velocity-command
locomotion policy's input); planned whole-body frames join it when the planner runs in
the loop.
"""

from __future__ import annotations

from dataclasses import dataclass

from controller.inputs.base import VelocityCommand


@dataclass(frozen=True)
class ReferenceWindow:
    """The reference from `time` (seconds on the run's clock) on.

    `velocity`: planar base velocity in the robot's heading frame (vx forward, vy left in
    m/s, yaw rate in rad/s); zero while standing or damped.
    """

    time: float
    velocity: VelocityCommand
