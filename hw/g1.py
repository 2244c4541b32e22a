"""Unitree G1 (29 DoF) constants, checked against the compiled MJCF by `tests/sim/test_constants.py`.

Joint order is the standard G1 order used by Unitree and holosoma. The default pose and
effort limits come from holosoma's G1 robot config and MJCF (holosoma 0.0.3 /
holosoma-inference 0.1.3, Apache-2.0).
"""

from __future__ import annotations

from collections.abc import Iterable

JOINT_NAMES: tuple[str, ...] = (
    "left_hip_pitch_joint", "left_hip_roll_joint", "left_hip_yaw_joint",
    "left_knee_joint", "left_ankle_pitch_joint", "left_ankle_roll_joint",
    "right_hip_pitch_joint", "right_hip_roll_joint", "right_hip_yaw_joint",
    "right_knee_joint", "right_ankle_pitch_joint", "right_ankle_roll_joint",
    "waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint",
    "left_shoulder_pitch_joint", "left_shoulder_roll_joint", "left_shoulder_yaw_joint",
    "left_elbow_joint", "left_wrist_roll_joint", "left_wrist_pitch_joint", "left_wrist_yaw_joint",
    "right_shoulder_pitch_joint", "right_shoulder_roll_joint", "right_shoulder_yaw_joint",
    "right_elbow_joint", "right_wrist_roll_joint", "right_wrist_pitch_joint", "right_wrist_yaw_joint",
)  # fmt: skip

NUM_JOINTS = len(JOINT_NAMES)

# Standing pose (rad) the locomotion policies were trained around.
DEFAULT_JOINT_POS: dict[str, float] = {
    "left_hip_pitch_joint": -0.312, "left_knee_joint": 0.669, "left_ankle_pitch_joint": -0.363,
    "right_hip_pitch_joint": -0.312, "right_knee_joint": 0.669, "right_ankle_pitch_joint": -0.363,
    "left_shoulder_pitch_joint": 0.2, "left_shoulder_roll_joint": 0.2, "left_elbow_joint": 0.6,
    "right_shoulder_pitch_joint": 0.2, "right_shoulder_roll_joint": -0.2, "right_elbow_joint": 0.6,
}  # fmt: skip

# Peak joint torque (N m), the MJCF's actuatorfrcrange per joint.
EFFORT_LIMITS: dict[str, float] = {
    "left_hip_pitch_joint": 88.0, "left_hip_roll_joint": 139.0, "left_hip_yaw_joint": 88.0,
    "left_knee_joint": 139.0, "left_ankle_pitch_joint": 50.0, "left_ankle_roll_joint": 50.0,
    "right_hip_pitch_joint": 88.0, "right_hip_roll_joint": 139.0, "right_hip_yaw_joint": 88.0,
    "right_knee_joint": 139.0, "right_ankle_pitch_joint": 50.0, "right_ankle_roll_joint": 50.0,
    "waist_yaw_joint": 88.0, "waist_roll_joint": 50.0, "waist_pitch_joint": 50.0,
    "left_shoulder_pitch_joint": 25.0, "left_shoulder_roll_joint": 25.0, "left_shoulder_yaw_joint": 25.0,
    "left_elbow_joint": 25.0, "left_wrist_roll_joint": 25.0, "left_wrist_pitch_joint": 5.0,
    "left_wrist_yaw_joint": 5.0,
    "right_shoulder_pitch_joint": 25.0, "right_shoulder_roll_joint": 25.0, "right_shoulder_yaw_joint": 25.0,
    "right_elbow_joint": 25.0, "right_wrist_roll_joint": 25.0, "right_wrist_pitch_joint": 5.0,
    "right_wrist_yaw_joint": 5.0,
}  # fmt: skip

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
