"""Plain data exchanged between a controller and any robot backend (sim or hardware)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class RobotState:
    """What a controller sees of the robot at one instant.

    Joint arrays follow the backend's joint order (names in `RobotInterface.joint_names`).
    `base_quat` is w, x, y, z of the pelvis in the world frame; `base_ang_vel` is the
    gyro reading in the pelvis frame. `base_pos`/`base_lin_vel` are world-frame and may be
    estimates on hardware. `imu_accel` is the IMU's specific force in the pelvis frame (m/s^2,
    gravity included: +9.81 up at rest) and `joint_tau` each joint's measured torque (N m); None
    where the robot does not report them.
    """

    time: float
    joint_pos: FloatArray
    joint_vel: FloatArray
    base_quat: FloatArray
    base_ang_vel: FloatArray
    base_pos: FloatArray
    base_lin_vel: FloatArray
    has_base_position: bool = True  # False where nothing estimates base_pos/base_lin_vel (they read zero)
    imu_accel: FloatArray | None = None
    joint_tau: FloatArray | None = None


def read_only(values: FloatArray) -> FloatArray:
    """`values` as a read-only float array: itself when it already is one, else a read-only copy."""
    array = np.asarray(values, dtype=np.float64)
    if array.flags.writeable:
        array = array.copy()
        array.flags.writeable = False
    return array


@dataclass(frozen=True)
class JointCommand:
    """Per-joint PD command: tau = kp * (q - q_meas) + kd * (dq - dq_meas) + tau_ff.

    Its arrays are read-only (writable inputs are copied): the hardware layer re-sends an
    unchanged command by identity, so an array changed in place after writing would
    otherwise go out stale. Producers that reuse arrays pass read-only ones (no copy).
    """

    q: FloatArray
    dq: FloatArray
    kp: FloatArray
    kd: FloatArray
    tau_ff: FloatArray

    def __post_init__(self) -> None:
        for name in ("q", "dq", "kp", "kd", "tau_ff"):
            object.__setattr__(self, name, read_only(getattr(self, name)))

    @staticmethod
    def damping(n: int, kd: float | FloatArray) -> JointCommand:
        """Zero stiffness, velocity damping only: the safe state of every joint."""
        zeros = np.zeros(n)
        return JointCommand(q=zeros, dq=zeros, kp=zeros, kd=np.broadcast_to(np.asarray(kd, float), (n,)).copy(), tau_ff=zeros)


class LimitedJoint(Protocol):
    """A joint's limits, joint side, as either joint-map kind holds them (a bus joint or a G1 joint over DDS)."""

    @property
    def position_limits(self) -> tuple[float, float]: ...
    @property
    def velocity_limit(self) -> float: ...
    @property
    def torque_limit(self) -> float: ...
