"""Named G1 joint groups and the qpos layout agree with the joint names, and index what they say."""

from __future__ import annotations

import numpy as np
import pytest

from hw import g1


def test_groups_hold_the_joints_their_names_say() -> None:
    assert all(n.startswith("left_") and n.split("_")[1] in ("hip", "knee", "ankle") for n in g1.LEFT_LEG_JOINTS)
    assert [n.replace("left_", "right_") for n in g1.LEFT_LEG_JOINTS] == list(g1.RIGHT_LEG_JOINTS)
    assert [n.replace("left_", "right_") for n in g1.LEFT_ARM_JOINTS] == list(g1.RIGHT_ARM_JOINTS)
    assert g1.WAIST_JOINTS == ("waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint")
    assert g1.LEFT_ARM_JOINTS[0] == "left_shoulder_pitch_joint" and g1.LEFT_ARM_JOINTS[-1] == "left_wrist_yaw_joint"
    sizes = [len(g) for g in (g1.LEFT_LEG_JOINTS, g1.RIGHT_LEG_JOINTS, g1.WAIST_JOINTS, g1.LEFT_ARM_JOINTS, g1.RIGHT_ARM_JOINTS)]
    assert sizes == [6, 6, 3, 7, 7]


def test_groups_partition_the_joints_in_joint_order() -> None:
    parts = g1.LEFT_LEG_JOINTS + g1.RIGHT_LEG_JOINTS + g1.WAIST_JOINTS + g1.LEFT_ARM_JOINTS + g1.RIGHT_ARM_JOINTS
    assert parts == g1.JOINT_NAMES
    assert g1.LEG_JOINTS == g1.LEFT_LEG_JOINTS + g1.RIGHT_LEG_JOINTS
    assert g1.ARM_JOINTS == g1.LEFT_ARM_JOINTS + g1.RIGHT_ARM_JOINTS
    assert g1.UPPER_BODY_JOINTS == g1.WAIST_JOINTS + g1.ARM_JOINTS
    assert g1.LEG_JOINTS + g1.UPPER_BODY_JOINTS == g1.JOINT_NAMES


def test_indices_and_slices_in_joint_and_qpos_order() -> None:
    joints = np.array(g1.JOINT_NAMES)
    qpos = np.array(["x", "y", "z", "qw", "qx", "qy", "qz", *g1.JOINT_NAMES])
    assert len(qpos) == g1.QPOS_SIZE
    for group in (g1.LEFT_LEG_JOINTS, g1.LEG_JOINTS, g1.WAIST_JOINTS, g1.RIGHT_ARM_JOINTS, g1.UPPER_BODY_JOINTS):
        assert tuple(joints[g1.joint_slice(group)]) == group
        assert tuple(qpos[g1.joint_slice(group, qpos=True)]) == group
        assert tuple(joints[g1.joint_indices(group)]) == group
        assert tuple(qpos[g1.joint_indices(group, qpos=True)]) == group
    assert g1.joint_slice(g1.LEG_JOINTS, qpos=True) == slice(7, 19)
    assert g1.joint_slice(g1.ARM_JOINTS) == slice(15, 29)
    assert g1.joint_indices(["right_knee_joint", "left_knee_joint"]) == [9, 3]  # the order given


def test_qpos_and_qvel_layout() -> None:
    qpos = np.array(["x", "y", "z", "qw", "qx", "qy", "qz", *g1.JOINT_NAMES])
    assert list(qpos[g1.QPOS_ROOT_POS]) == ["x", "y", "z"] and list(qpos[g1.QPOS_ROOT_QUAT]) == ["qw", "qx", "qy", "qz"]
    assert tuple(qpos[g1.QPOS_JOINTS]) == g1.JOINT_NAMES
    assert list(qpos[g1.QPOS_ROOT]) == ["x", "y", "z", "qw", "qx", "qy", "qz"]
    qvel = np.array(["vx", "vy", "vz", "wx", "wy", "wz", *g1.JOINT_NAMES])
    assert len(qvel) == g1.QVEL_SIZE == 35
    assert list(qvel[g1.QVEL_ROOT_LIN]) == ["vx", "vy", "vz"] and list(qvel[g1.QVEL_ROOT_ANG]) == ["wx", "wy", "wz"]
    assert tuple(qvel[g1.QVEL_JOINTS]) == g1.JOINT_NAMES
    assert list(qvel[g1.QVEL_ROOT]) == ["vx", "vy", "vz", "wx", "wy", "wz"]


def test_bad_groups_fail_loudly() -> None:
    with pytest.raises(ValueError, match="not one contiguous run"):
        g1.joint_slice(g1.LEFT_LEG_JOINTS + g1.LEFT_ARM_JOINTS)
    with pytest.raises(ValueError, match="not one contiguous run"):
        g1.joint_slice(("right_knee_joint", "left_knee_joint"))
    with pytest.raises(ValueError, match="not one contiguous run"):
        g1.joint_slice(())
    with pytest.raises(ValueError, match="unknown G1 joints.*left_hand_joint"):
        g1.joint_indices(["left_hip_pitch_joint", "left_hand_joint"])
