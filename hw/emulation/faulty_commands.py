"""A controller gone wrong, for the host-side drills: its commands turn NaN or wild from a set time.

Only what the controller computes goes bad (commands with stiffness); a damping command
passes untouched, as the supervisor's damping does not come from the policy. What reaches
the motors is then up to the safety layer behind it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hw.emulation.faults import HostFaults
from hw.robot import RobotInterface
from hw.types import JointCommand, RobotState

WILD_POSITION_RAD = 10.0
WILD_VELOCITY_RAD_S = 1e3
WILD_TORQUE_NM = 1e4


class FaultyCommands(RobotInterface):
    def __init__(self, robot: RobotInterface, faults: HostFaults, now: Callable[[], float]) -> None:
        super().__init__()
        self.robot, self.faults, self.now = robot, faults, now
        self.corrupted = 0  # commands replaced

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.robot.joint_names

    def read(self) -> RobotState:
        return self.robot.read()

    def write(self, command: JointCommand) -> None:
        self.robot.write(self._corrupt(command) if (command.kp > 0).any() else command)

    def _corrupt(self, command: JointCommand) -> JointCommand:
        t, f = self.now(), self.faults
        n = len(command.q)
        if f.nan_command_s is not None and t >= f.nan_command_s:
            self.corrupted += 1
            return JointCommand(q=np.full(n, np.nan), dq=command.dq, kp=command.kp, kd=command.kd, tau_ff=command.tau_ff)
        if f.wild_command_s is not None and t >= f.wild_command_s:
            self.corrupted += 1
            sign = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)  # both ends of every range
            return JointCommand(
                q=sign * WILD_POSITION_RAD, dq=sign * WILD_VELOCITY_RAD_S, kp=command.kp, kd=command.kd, tau_ff=sign * WILD_TORQUE_NM
            )
        return command

    def damp(self) -> None:
        self.robot.damp()
