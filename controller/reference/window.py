"""The reference window: what a tracker is asked to follow at one tick.

Every tracker reads the same value, so the session never needs to know which tracker
runs: the supervised velocity command (the velocity-command locomotion policy's input)
and, when the planner runs in the loop, the plan sampled now and a little ahead.
"""

from __future__ import annotations

from dataclasses import dataclass

from controller.commands.velocity import VelocityCommand
from controller.reference.buffer import ReferenceSample


@dataclass(frozen=True)
class ReferenceWindow:
    """The reference from `time` (seconds on the run's clock) on.

    `velocity`: planar base velocity in the robot's heading frame (vx forward, vy left in
    m/s, yaw rate in rad/s); zero while standing or damped. `plan`, `ahead`: samples of the
    reference buffer (pose, root and joint velocities).
    """

    time: float
    velocity: VelocityCommand
    plan: ReferenceSample | None = None  # the planned motion at `time` (None: no planner in the loop)
    ahead: ReferenceSample | None = None  # the planned motion a little later: what the robot should move towards
    path_velocity: VelocityCommand | None = None  # the planned root path's velocity (heading frame) a little ahead
