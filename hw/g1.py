"""Unitree G1 (29 DoF) constants, checked against the compiled MJCF by `tests/sim/test_constants.py`.

Joint order is the standard G1 order used by Unitree and holosoma. The default pose and
effort limits come from holosoma's G1 robot config and MJCF (holosoma 0.0.3 /
holosoma-inference 0.1.3, Apache-2.0).
"""

from __future__ import annotations

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

QPOS_SIZE = 7 + NUM_JOINTS  # root xyz + root quaternion wxyz + joints
ROOT_BODY = "pelvis"
TORSO_BODY = "torso_link"
IMU_SITE = "imu_in_pelvis"
FOOT_BODIES = ("left_ankle_roll_link", "right_ankle_roll_link")

# Pelvis height (m) with the default pose standing on flat ground, feet just touching.
STANDING_PELVIS_HEIGHT = 0.78


def default_joint_vector() -> list[float]:
    """Default pose as a list in `JOINT_NAMES` order."""
    return [DEFAULT_JOINT_POS.get(name, 0.0) for name in JOINT_NAMES]
