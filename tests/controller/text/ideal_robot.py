"""An ideal robot ticked one step at a time under a reference source: its root moves exactly as commanded (the kinematic
module's, `controller.text.kinematic.ideal_state`), for tests that act between ticks."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from controller.commands.velocity import ZERO, VelocityCommand
from controller.reference.planned import PlannedReference
from controller.reference.source import ReferenceSource
from controller.reference.window import ReferenceWindow
from controller.text.kinematic import ideal_state
from hw import g1
from hw.types import RobotState


class IdealRobot:
    def __init__(self, reference: ReferenceSource, planned: PlannedReference, rate_hz: float = 50.0) -> None:
        self.reference, self.planned, self.dt = reference, planned, 1.0 / rate_hz
        self.t, self.pose, self.velocity = 0.0, (0.0, 0.0, 0.0), ZERO
        qpos = np.array(g1.standing_qpos())
        self.state = RobotState(
            time=0.0, joint_pos=qpos[g1.QPOS_JOINTS], joint_vel=np.zeros(g1.NUM_JOINTS), base_quat=qpos[g1.QPOS_ROOT_QUAT],
            base_ang_vel=np.zeros(3), base_pos=qpos[g1.QPOS_ROOT_POS], base_lin_vel=np.zeros(3),
        )  # fmt: skip
        self.window: ReferenceWindow | None = None
        reference.start(self.state)

    def tick(self, device: VelocityCommand = ZERO, gesture: str = "", hold: bool = False) -> ReferenceWindow:
        """One control period: the robot moves on the last command, then the reference is asked with the device's."""
        x, y, heading = self.pose
        c, s = math.cos(heading), math.sin(heading)
        v, dt = self.velocity, self.dt
        self.pose = (x + dt * (c * v.vx - s * v.vy), y + dt * (s * v.vx + c * v.vy), heading + dt * v.yaw_rate)
        self.t += dt
        self.state = ideal_state(self.planned.buffer.sample(self.t), self.pose, self.velocity, self.t)
        self.window = self.reference.window(self.state, device, gesture, hold)
        self.velocity = self.window.velocity
        return self.window

    def run(self, seconds: float, device: VelocityCommand = ZERO, gesture: str = "", hold: bool = False) -> None:
        for _ in range(round(seconds / self.dt)):
            self.tick(device, gesture, hold)

    def until(self, condition: Callable[[], bool], max_seconds: float, device: VelocityCommand = ZERO) -> bool:
        """Tick until `condition` holds (True) or `max_seconds` of run time pass (False)."""
        for _ in range(round(max_seconds / self.dt)):
            if condition():
                return True
            self.tick(device)
        return condition()
