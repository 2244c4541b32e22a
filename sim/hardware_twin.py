"""MuJoCo as the plant behind simulated hardware (`hw.emulation.rig.SimulatedHardware`)."""

from __future__ import annotations

import threading

import numpy as np

from hw import g1
from hw.types import JointCommand
from sim.robot import SimRobot

GRAVITY_MPS2 = 9.81


class MuJoCoPlant:
    """The emulators' view of the simulated G1: joint states and per-joint PD laws."""

    def __init__(self, robot: SimRobot, gantry_height: float | None = None) -> None:
        """`gantry_height`: hang the pelvis this far above its standing height, fixed in
        space (a bench gantry), so bring-up can move joints without the robot falling."""
        self.robot = robot
        self.lock = threading.RLock()
        names = robot.joint_names
        self._index = {name: i for i, name in enumerate(names)}
        n = len(names)
        self._q, self._dq, self._kp, self._kd, self._tau = (np.zeros(n) for _ in range(5))
        model, data = robot.model, robot.data
        self._qadr = [model.jnt_qposadr[model.joint(j).id] for j in names]
        self._vadr = [model.jnt_dofadr[model.joint(j).id] for j in names]
        self._aid = [model.actuator(j).id for j in names]
        self._data = data
        self._gantry: np.ndarray | None = None
        if gantry_height is not None:
            data.qpos[2] += gantry_height  # root z
            self._gantry = data.qpos[g1.QPOS_ROOT].copy()
        robot.damp()  # limp until the first command arrives: zero gains
        self.robot.write(JointCommand(q=self._q, dq=self._dq, kp=self._kp, kd=self._kd, tau_ff=self._tau))

    def time(self) -> float:
        return float(self._data.time)

    def joint_state(self, joint: str) -> tuple[float, float, float]:
        i = self._index[joint]
        d = self._data
        return float(d.qpos[self._qadr[i]]), float(d.qvel[self._vadr[i]]), float(d.actuator_force[self._aid[i]])

    def set_joint_command(self, joint: str, q: float, dq: float, kp: float, kd: float, tau: float) -> None:
        i = self._index[joint]
        self._q[i], self._dq[i], self._kp[i], self._kd[i], self._tau[i] = q, dq, kp, kd, tau

    def imu_reading(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """Attitude, rates and the accelerometer's specific force (gravity included), as the pelvis IMU measures them."""
        d = self._data
        accel = self.robot.imu_accel() if self._gantry is None else self._at_rest_accel()
        return tuple(d.qpos[g1.QPOS_ROOT_QUAT].tolist()), tuple(d.qvel[g1.QVEL_ROOT_ANG].tolist()), tuple(accel.tolist())

    def _at_rest_accel(self) -> np.ndarray:
        """On the gantry the pelvis is held still: the accelerometer feels gravity's reaction only."""
        w, x, y, z = self._data.qpos[g1.QPOS_ROOT_QUAT].tolist()
        return GRAVITY_MPS2 * np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])

    def step(self) -> None:
        with self.lock:
            self.robot.write(
                JointCommand(q=self._q.copy(), dq=self._dq.copy(), kp=self._kp.copy(), kd=self._kd.copy(), tau_ff=self._tau.copy())
            )
            self.robot.step(1)
            if self._gantry is not None:
                self._data.qpos[g1.QPOS_ROOT] = self._gantry
                self._data.qvel[g1.QVEL_ROOT] = 0.0
