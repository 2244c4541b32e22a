"""Plain data exchanged between a controller and any robot backend (sim or hardware)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class RobotState:
    """What a controller sees of the robot at one instant.

    Joint arrays follow the backend's joint order (names in `RobotInterface.joint_names`).
    `base_quat` is w, x, y, z of the pelvis in the world frame; `base_ang_vel` is the
    gyro reading in the pelvis frame. `base_pos`/`base_lin_vel` are world-frame and may be
    estimates on hardware.
    """

    time: float
    joint_pos: FloatArray
    joint_vel: FloatArray
    base_quat: FloatArray
    base_ang_vel: FloatArray
    base_pos: FloatArray
    base_lin_vel: FloatArray


@dataclass(frozen=True)
class JointCommand:
    """Per-joint PD command: tau = kp * (q - q_meas) + kd * (dq - dq_meas) + tau_ff."""

    q: FloatArray
    dq: FloatArray
    kp: FloatArray
    kd: FloatArray
    tau_ff: FloatArray

    @staticmethod
    def damping(n: int, kd: float | FloatArray) -> JointCommand:
        """Zero stiffness, velocity damping only: the safe state of every joint."""
        zeros = np.zeros(n)
        return JointCommand(q=zeros, dq=zeros, kp=zeros, kd=np.broadcast_to(np.asarray(kd, float), (n,)).copy(), tau_ff=zeros)
