"""The constants module agrees with the compiled G1 MJCF."""

from __future__ import annotations

import numpy as np

from hw import g1 as constants
from sim.kinematics import FOOT_CONTACT_BODIES


def test_joint_order_matches_model(g1_model) -> None:
    names = [g1_model.joint(i).name for i in range(g1_model.njnt)]
    assert names[0] == "floating_base_joint"
    assert tuple(names[1:]) == constants.JOINT_NAMES
    assert g1_model.nq == constants.QPOS_SIZE == 36
    assert [g1_model.actuator(i).name for i in range(g1_model.nu)] == list(constants.JOINT_NAMES)


def test_effort_limits_match_model(g1_model) -> None:
    for name in constants.JOINT_NAMES:
        joint = g1_model.joint(name)
        assert g1_model.jnt_actfrcrange[joint.id][1] == constants.EFFORT_LIMITS[name], name
        assert g1_model.actuator(name).forcerange[1] == constants.EFFORT_LIMITS[name], name


def test_default_pose_within_joint_ranges(g1_model) -> None:
    for name, q in zip(constants.JOINT_NAMES, constants.default_joint_vector(), strict=True):
        joint = g1_model.joint(name)
        if g1_model.jnt_limited[joint.id]:
            lo, hi = joint.range
            assert lo <= q <= hi, name
    assert set(constants.DEFAULT_JOINT_POS) <= set(constants.JOINT_NAMES)


def test_named_bodies_exist(g1_model) -> None:
    for body in (constants.ROOT_BODY, constants.TORSO_BODY, *constants.ANKLE_BODIES, *FOOT_CONTACT_BODIES):
        assert g1_model.body(body).id > 0
    assert g1_model.site(constants.IMU_SITE).id >= 0
    assert np.isclose(g1_model.opt.timestep, 0.002)
