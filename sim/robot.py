"""The simulated G1: the robot interface over MuJoCo physics, with fall detection."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from hw import g1 as constants
from hw import quat
from hw.errors import ConfigError
from hw.robot import RobotInterface
from hw.types import FloatArray, JointCommand, RobotState

IMU_ACCELEROMETER = "base_accel"  # the G1 model's accelerometer at the pelvis IMU (site imu_in_pelvis, axes the pelvis's)
FLOOR_GEOM = "floor"  # the scene's ground (`sim.world`): a plane, or a height field on uneven ground


@dataclass(frozen=True)
class FallConfig:
    """A fall is the pelvis below `min_pelvis_height` or the torso tilted past `max_tilt_deg`."""

    min_pelvis_height: float = 0.45
    max_tilt_deg: float = 60.0


class SimRobot(RobotInterface):
    """G1 in MuJoCo. Joint PD runs inside the physics step (see `sim.world`)."""

    def __init__(self, model: mujoco.MjModel, fall: FallConfig = FallConfig(), damping_kd: float = constants.DAMPING_KD) -> None:
        super().__init__()
        self.model = model
        self.data = mujoco.MjData(model)
        self.fall = fall
        self._damping_kd = damping_kd
        self._qpos_adr = _as_slice([model.jnt_qposadr[model.joint(n).id] for n in constants.JOINT_NAMES])
        self._dof_adr = _as_slice([model.jnt_dofadr[model.joint(n).id] for n in constants.JOINT_NAMES])
        self._act_ids = _as_slice([model.actuator(n).id for n in constants.JOINT_NAMES])
        if model.nu != constants.NUM_JOINTS:
            raise ConfigError(f"G1 model has {model.nu} actuators, expected {constants.NUM_JOINTS}")
        self._torso_id = model.body(constants.TORSO_BODY).id
        accel = model.sensor(IMU_ACCELEROMETER)
        self._accel_adr = slice(int(model.sensor_adr[accel.id]), int(model.sensor_adr[accel.id]) + 3)
        self._cos_max_tilt = float(np.cos(np.deg2rad(fall.max_tilt_deg)))
        self._floor_id = model.geom(FLOOR_GEOM).id
        # Each geom's foot: 1 left, 2 right (a collision geom of that ankle body), 0 none; a lookup per contact.
        foot_of_geom = np.zeros(model.ngeom, dtype=np.int64)
        for side, body in enumerate(constants.ANKLE_BODIES, start=1):
            touching = (model.geom_bodyid == model.body(body).id) & ((model.geom_contype | model.geom_conaffinity) != 0)
            foot_of_geom[touching] = side
        self._foot_of_geom: list[int] = foot_of_geom.tolist()
        self._gains: tuple[FloatArray | None, FloatArray | None] = (None, None)
        self.reset()

    @property
    def joint_names(self) -> tuple[str, ...]:
        return constants.JOINT_NAMES

    @property
    def time(self) -> float:
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    def joint_limits(self) -> tuple[FloatArray, FloatArray]:
        """Lower and upper position limits (rad) of the joints, from the model, in `joint_names` order."""
        ranges = np.array([self.model.jnt_range[self.model.joint(name).id] for name in self.joint_names])
        return ranges[:, 0].copy(), ranges[:, 1].copy()

    def reset(self, joint_pos: FloatArray | None = None, yaw: float = 0.0) -> None:
        """Stand the robot at the origin in the default pose (or `joint_pos`), damped; time runs on."""
        t = self.data.time
        mujoco.mj_resetData(self.model, self.data)
        self.data.time = t
        q = np.asarray(constants.default_joint_vector() if joint_pos is None else joint_pos, float)
        self.data.qpos[constants.QPOS_ROOT_POS] = [0.0, 0.0, constants.STANDING_PELVIS_HEIGHT]
        self.data.qpos[constants.QPOS_ROOT_QUAT] = quat.from_yaw(yaw)
        self.data.qpos[self._qpos_adr] = q
        mujoco.mj_forward(self.model, self.data)
        self.write(
            JointCommand(q=q, dq=np.zeros_like(q), kp=np.zeros_like(q), kd=np.full_like(q, self._damping_kd), tau_ff=np.zeros_like(q))
        )

    def read(self) -> RobotState:
        d = self.data
        return RobotState(
            time=float(d.time),
            joint_pos=d.qpos[self._qpos_adr].copy(),
            joint_vel=d.qvel[self._dof_adr].copy(),
            base_quat=d.qpos[constants.QPOS_ROOT_QUAT].copy(),
            base_ang_vel=d.qvel[constants.QVEL_ROOT_ANG].copy(),  # free-joint angular velocity is in the body frame
            base_pos=d.qpos[constants.QPOS_ROOT_POS].copy(),
            base_lin_vel=d.qvel[constants.QVEL_ROOT_LIN].copy(),
            imu_accel=self.imu_accel(),
            joint_tau=d.actuator_force[self._act_ids].copy(),
        )

    def imu_accel(self) -> FloatArray:
        """The pelvis IMU's accelerometer (specific force in its frame, gravity included), as of the last physics step."""
        return self.data.sensordata[self._accel_adr].copy()

    def foot_contacts(self) -> tuple[bool, bool]:
        """Left, right: whether any collision geom of the foot touches the floor, as of the last physics step."""
        floor, foot_of_geom = self._floor_id, self._foot_of_geom
        left = right = False
        for first, second in self.data.contact.geom[: self.data.ncon].tolist():  # a few contacts: plain ints beat numpy here
            side = foot_of_geom[second] if first == floor else foot_of_geom[first] if second == floor else 0
            left, right = left or side == 1, right or side == 2
        return left, right

    def write(self, command: JointCommand) -> None:
        """Load the PD law into the actuators: force = kp q* + kd dq* + tau - kp q - kd dq."""
        m, ids = self.model, self._act_ids
        if command.kp is not self._gains[0] or command.kd is not self._gains[1]:  # policies reuse their gain arrays
            m.actuator_biasprm[ids, 1] = -command.kp
            m.actuator_biasprm[ids, 2] = -command.kd
            self._gains = (command.kp, command.kd)
        self.data.ctrl[ids] = command.kp * command.q + command.kd * command.dq + command.tau_ff

    def damp(self) -> None:
        n = constants.NUM_JOINTS
        self.write(JointCommand.damping(n, self._damping_kd))

    def step(self, n: int = 1) -> None:
        """Advance physics by `n` timesteps under the last command."""
        mujoco.mj_step(self.model, self.data, nstep=n)

    def step_until(self, t: float) -> None:
        """Advance physics to the first step at or after time `t`."""
        n = int(np.ceil((t - self.data.time) / self.model.opt.timestep - 1e-6))
        if n > 0:
            self.step(n)

    def mirror(self, qpos: FloatArray, qvel: FloatArray, time: float) -> None:
        """Take another simulator's state (a robot in another process) without stepping: positions, velocities, kinematics."""
        self.data.qpos[:], self.data.qvel[:], self.data.time = qpos, qvel, time
        mujoco.mj_forward(self.model, self.data)

    def has_fallen(self) -> bool:
        if self.data.qpos[2] < self.fall.min_pelvis_height:
            return True
        torso_up_z = self.data.xmat[self._torso_id][8]  # world z of the torso's z axis
        return bool(torso_up_z < self._cos_max_tilt)

    def qpos(self) -> FloatArray:
        """MuJoCo qpos in the standard G1 layout (36 floats)."""
        return self.data.qpos.copy()


def _as_slice(indices: list[int]) -> slice | np.ndarray:
    """A slice when the indices are contiguous (a view, much cheaper per tick), else an index array."""
    if indices == list(range(indices[0], indices[0] + len(indices))):
        return slice(indices[0], indices[0] + len(indices))
    return np.asarray(indices)
