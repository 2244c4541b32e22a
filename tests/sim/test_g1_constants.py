"""The constants module agrees with the compiled G1 MJCF."""

from __future__ import annotations

from pathlib import Path

from hw import g1 as constants
from sim.dds_robot import DdsRobotConfig
from sim.kinematics import FOOT_CONTACT_BODIES


def test_joint_order_matches_model(g1_model) -> None:
    names = [g1_model.joint(i).name for i in range(g1_model.njnt)]
    assert names[0] == "floating_base_joint"
    assert tuple(names[1:]) == constants.JOINT_NAMES
    assert g1_model.nq == constants.QPOS_SIZE == 36
    assert [g1_model.actuator(i).name for i in range(g1_model.nu)] == list(constants.JOINT_NAMES)


def test_joint_table_limits_are_the_models(g1_model) -> None:
    """Each joint's position and effort limits in the table are the compiled MJCF's joint range and force range."""
    for joint in constants.G1_JOINTS:
        model_joint = g1_model.joint(joint.name)
        assert g1_model.jnt_limited[model_joint.id], joint.name
        assert tuple(model_joint.range) == joint.position_limits, joint.name
        assert g1_model.jnt_actfrclimited[model_joint.id], joint.name
        assert tuple(g1_model.jnt_actfrcrange[model_joint.id]) == (-joint.effort_limit, joint.effort_limit), joint.name
        assert tuple(g1_model.actuator(joint.name).forcerange) == (-joint.effort_limit, joint.effort_limit), joint.name
    assert {joint.name: joint.effort_limit for joint in constants.G1_JOINTS} == constants.EFFORT_LIMITS


def test_joint_table_gains_and_velocity_limits_are_usable() -> None:
    for joint in constants.G1_JOINTS:
        assert joint.kp > 0 and joint.kd > 0 and joint.velocity_limit > 0, joint.name


def test_default_pose_within_joint_ranges(g1_model) -> None:
    for joint, q in zip(constants.G1_JOINTS, constants.default_joint_vector(), strict=True):
        lo, hi = g1_model.joint(joint.name).range
        assert lo <= q <= hi and joint.default_pos == q, joint.name
    assert set(constants.DEFAULT_JOINT_POS) <= set(constants.JOINT_NAMES)


def test_named_bodies_exist(g1_model) -> None:
    for body in (constants.ROOT_BODY, constants.TORSO_BODY, *constants.ANKLE_BODIES, *FOOT_CONTACT_BODIES):
        assert g1_model.body(body).id > 0
    assert g1_model.site(constants.IMU_SITE).id >= 0


def test_the_physics_step_is_the_hardware_cycle(g1_model) -> None:
    """One value, the others derived: the simulator steps once per hardware cycle (500 Hz: 2 ms), and so does
    the simulated robot behind DDS."""
    assert g1_model.opt.timestep == 1.0 / constants.CONTROL_CYCLE_HZ == 0.002
    assert DdsRobotConfig(mjcf=Path("g1.xml")).period_s == g1_model.opt.timestep
