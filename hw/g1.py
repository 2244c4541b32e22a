"""Unitree G1 (29 DoF) constants, checked against the compiled MJCF by `tests/sim/test_g1_constants.py`.

`G1_JOINTS` is the one table of the robot's joints: their order, limits, bring-up gains and
standing pose. Everything else reads it (the simulator's force limits, the hardware configs'
defaults and their override check, the policies' default pose). Joint order is the standard
G1 order used by Unitree and holosoma. Position and effort limits are the MJCF's joint ranges
and `actuatorfrcrange`s; the default pose is holosoma's G1 `default_dof_angles` (holosoma 0.0.3 /
holosoma-inference 0.1.3, Apache-2.0).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

# rad/s: the joint velocity a command's velocity target is clamped to, every joint alike. The MJCF
# states no velocity limit; Unitree's G1 URDF (carried in the holosoma wbt exports' metadata) gives
# 20 to 37 rad/s per joint, below this bound for the hip roll and knee (20) and wrist pitch and yaw (22).
COMMAND_VELOCITY_LIMIT = 30.0


@dataclass(frozen=True)
class G1Joint:
    """One joint of the G1, joint side: what a hardware config takes unless it narrows a limit or changes a gain."""

    name: str
    position_limits: tuple[float, float]  # rad: the MJCF joint's range
    effort_limit: float  # N m: the MJCF joint's actuatorfrcrange, the torque the physics clamps to
    # Bring-up gains (soft start, sweeps): the holosoma policies' gains (their ONNX metadata) rounded, except
    # hip roll 40 / 2.5 (policies 99.1 / 6.3), waist roll and pitch 40 / 2.5 (28.5 / 1.8), wrist roll 16.8 / 1.1 (14.3 / 0.9).
    kp: float  # N m/rad
    kd: float  # N m s/rad
    default_pos: float = 0.0  # rad: the standing pose the locomotion policies were trained around
    velocity_limit: float = COMMAND_VELOCITY_LIMIT  # rad/s


_J = G1Joint
G1_JOINTS: tuple[G1Joint, ...] = (
    #  name                          position limits       effort   kp    kd   default pose
    _J("left_hip_pitch_joint",       (-2.5307, 2.8798),     88.0,  40.0, 2.5, -0.312),
    _J("left_hip_roll_joint",        (-0.5236, 2.9671),    139.0,  40.0, 2.5),
    _J("left_hip_yaw_joint",         (-2.7576, 2.7576),     88.0,  40.0, 2.5),
    _J("left_knee_joint",            (-0.087267, 2.8798),  139.0,  99.0, 6.3,  0.669),
    _J("left_ankle_pitch_joint",     (-0.87267, 0.5236),    50.0,  28.5, 1.8, -0.363),
    _J("left_ankle_roll_joint",      (-0.2618, 0.2618),     50.0,  28.5, 1.8),
    _J("right_hip_pitch_joint",      (-2.5307, 2.8798),     88.0,  40.0, 2.5, -0.312),
    _J("right_hip_roll_joint",       (-2.9671, 0.5236),    139.0,  40.0, 2.5),
    _J("right_hip_yaw_joint",        (-2.7576, 2.7576),     88.0,  40.0, 2.5),
    _J("right_knee_joint",           (-0.087267, 2.8798),  139.0,  99.0, 6.3,  0.669),
    _J("right_ankle_pitch_joint",    (-0.87267, 0.5236),    50.0,  28.5, 1.8, -0.363),
    _J("right_ankle_roll_joint",     (-0.2618, 0.2618),     50.0,  28.5, 1.8),
    _J("waist_yaw_joint",            (-2.618, 2.618),       88.0,  40.0, 2.5),
    _J("waist_roll_joint",           (-0.52, 0.52),         50.0,  40.0, 2.5),
    _J("waist_pitch_joint",          (-0.52, 0.52),         50.0,  40.0, 2.5),
    _J("left_shoulder_pitch_joint",  (-3.0892, 2.6704),     25.0,  14.3, 0.9,  0.2),
    _J("left_shoulder_roll_joint",   (-1.5882, 2.2515),     25.0,  14.3, 0.9,  0.2),
    _J("left_shoulder_yaw_joint",    (-2.618, 2.618),       25.0,  14.3, 0.9),
    _J("left_elbow_joint",           (-1.0472, 2.0944),     25.0,  14.3, 0.9,  0.6),
    _J("left_wrist_roll_joint",      (-1.97222, 1.97222),   25.0,  16.8, 1.1),
    _J("left_wrist_pitch_joint",     (-1.61443, 1.61443),    5.0,  16.8, 1.1),
    _J("left_wrist_yaw_joint",       (-1.61443, 1.61443),    5.0,  16.8, 1.1),
    _J("right_shoulder_pitch_joint", (-3.0892, 2.6704),     25.0,  14.3, 0.9,  0.2),
    _J("right_shoulder_roll_joint",  (-2.2515, 1.5882),     25.0,  14.3, 0.9, -0.2),
    _J("right_shoulder_yaw_joint",   (-2.618, 2.618),       25.0,  14.3, 0.9),
    _J("right_elbow_joint",          (-1.0472, 2.0944),     25.0,  14.3, 0.9,  0.6),
    _J("right_wrist_roll_joint",     (-1.97222, 1.97222),   25.0,  16.8, 1.1),
    _J("right_wrist_pitch_joint",    (-1.61443, 1.61443),    5.0,  16.8, 1.1),
    _J("right_wrist_yaw_joint",      (-1.61443, 1.61443),    5.0,  16.8, 1.1),
)  # fmt: skip
del _J

G1_JOINT: dict[str, G1Joint] = {joint.name: joint for joint in G1_JOINTS}
JOINT_NAMES: tuple[str, ...] = tuple(G1_JOINT)
NUM_JOINTS = len(JOINT_NAMES)

# Views of the table by joint name.
# The standing pose's non-zero joints (rad); a joint not listed stands at 0.
DEFAULT_JOINT_POS: dict[str, float] = {j.name: j.default_pos for j in G1_JOINTS if j.default_pos != 0.0}
# Peak joint torque (N m) per joint.
EFFORT_LIMITS: dict[str, float] = {j.name: j.effort_limit for j in G1_JOINTS}

# Rate (Hz) of the hardware cycle: one command to and one reply from every motor per period
# (the G1's rt/lowcmd rate; bring-up and the hardware runtime pace their loops on it).
CONTROL_CYCLE_HZ = 500.0

# Joint damping (N m s/rad, joint side) of the safe state, zero stiffness: what the safety
# layer, the simulated robot and the policies send when they damp.
DAMPING_KD = 2.0

QPOS_SIZE = 7 + NUM_JOINTS  # root xyz + root quaternion wxyz + joints
ROOT_BODY = "pelvis"
TORSO_BODY = "torso_link"
IMU_SITE = "imu_in_pelvis"
ANKLE_BODIES = ("left_ankle_roll_link", "right_ankle_roll_link")  # the feet's links: their geoms touch the floor

# Pelvis height (m) with the default pose standing on flat ground, feet just touching.
STANDING_PELVIS_HEIGHT = 0.78


def default_joint_vector() -> list[float]:
    """Default pose as a list in `JOINT_NAMES` order."""
    return [DEFAULT_JOINT_POS.get(name, 0.0) for name in JOINT_NAMES]


def standing_qpos() -> list[float]:
    """The G1 standing in the default pose at the origin, facing +x: a full MuJoCo qpos (36 values)."""
    return [0.0, 0.0, STANDING_PELVIS_HEIGHT, 1.0, 0.0, 0.0, 0.0, *default_joint_vector()]


# ---- qpos layout ----------------------------------------------------------------------------

QPOS_ROOT_POS = slice(0, 3)  # root position xyz (m, world frame)
QPOS_ROOT_QUAT = slice(3, 7)  # root quaternion w, x, y, z
QPOS_JOINTS = slice(7, QPOS_SIZE)  # joint angles in JOINT_NAMES order
QPOS_ROOT = slice(0, 7)  # the floating base's whole pose: position and quaternion
QVEL_SIZE = 6 + NUM_JOINTS  # MuJoCo qvel: root linear velocity (world), root angular velocity (body), joints
QVEL_ROOT_LIN = slice(0, 3)
QVEL_ROOT_ANG = slice(3, 6)
QVEL_JOINTS = slice(6, QVEL_SIZE)
QVEL_ROOT = slice(0, 6)


# ---- joint groups ---------------------------------------------------------------------------
# Picked from JOINT_NAMES by name, so each group is in joint order whatever the counts.


def _joints_where(side: str, parts: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(name for name in JOINT_NAMES if name.startswith(f"{side}_") and name.split("_")[1] in parts)


_LEG_PARTS, _ARM_PARTS = ("hip", "knee", "ankle"), ("shoulder", "elbow", "wrist")
LEFT_LEG_JOINTS = _joints_where("left", _LEG_PARTS)
RIGHT_LEG_JOINTS = _joints_where("right", _LEG_PARTS)
WAIST_JOINTS = tuple(name for name in JOINT_NAMES if name.startswith("waist_"))
LEFT_ARM_JOINTS = _joints_where("left", _ARM_PARTS)
RIGHT_ARM_JOINTS = _joints_where("right", _ARM_PARTS)
LEG_JOINTS = tuple(name for name in JOINT_NAMES if name in LEFT_LEG_JOINTS + RIGHT_LEG_JOINTS)
ARM_JOINTS = tuple(name for name in JOINT_NAMES if name in LEFT_ARM_JOINTS + RIGHT_ARM_JOINTS)
UPPER_BODY_JOINTS = tuple(name for name in JOINT_NAMES if name in WAIST_JOINTS + ARM_JOINTS)


def joint_indices(group: Iterable[str], qpos: bool = False) -> list[int]:
    """Indices of the named joints, in the order given, in the joint vector (or in `qpos` with `qpos=True`).

    A list, not a tuple, so that it indexes numpy arrays as one axis.
    """
    offset = QPOS_JOINTS.start if qpos else 0
    unknown = [name for name in group if name not in JOINT_NAMES]
    if unknown:
        raise ValueError(f"unknown G1 joints {unknown}; valid names are in hw.g1.JOINT_NAMES")
    return [offset + JOINT_NAMES.index(name) for name in group]


def joint_slice(group: Iterable[str], qpos: bool = False) -> slice:
    """The slice of the joint vector (or of `qpos`) that holds exactly `group`, which must be one run in joint order."""
    names = tuple(group)
    index = joint_indices(names, qpos)
    if not index or index != list(range(index[0], index[0] + len(index))):
        raise ValueError(f"joints {list(names)} are not one contiguous run in joint order; index them with joint_indices")
    return slice(index[0], index[-1] + 1)
