"""What one control tick hands to a recorder: plain references to what the session read, decided and sent."""

from __future__ import annotations

from dataclasses import dataclass

from controller.commands.velocity import VelocityCommand
from controller.inputs.base import CommandSample
from controller.reference.window import ReferenceWindow
from hw.types import JointCommand, RobotState


@dataclass(frozen=True, slots=True)
class Tick:
    """One tick, as `Session.tick` saw it; the recorder copies what it keeps before the tick returns.

    `reading` is the robot's state as read, `state` what the controller saw (the estimate where an
    estimator runs, else the reading itself), `truth` the simulator's ground truth where one stands
    behind a robot that is not itself (None on a real robot). `velocity` is what the supervisor let
    through (zero unless running), `measured_velocity` the tracking metrics' measurement of this
    tick (vx, vy, yaw rate in the heading frame; None on a tick that gave none).
    """

    state: RobotState
    reading: RobotState
    truth: RobotState | None
    sample: CommandSample
    velocity: VelocityCommand
    measured_velocity: tuple[float, float, float] | None
    mode: str
    reason: str  # why the robot is damped or held ("" while it runs)
    fault: str | None  # the fault the supervisor was given this tick (the tracker's or the backend's)
    window: ReferenceWindow
    command: JointCommand
    fell: bool
