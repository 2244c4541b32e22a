"""The numpy leg kinematics against MuJoCo's own, on the G1 model."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from controller.assets import Assets
from controller.estimation.kinematics import LegKinematics
from hw import g1
from hw.errors import AssetError


def test_feet_velocities_and_jacobians_match_mujoco(assets: Assets, g1_model: mujoco.MjModel) -> None:
    kin = LegKinematics.from_mjcf(assets.g1_mjcf)
    data = mujoco.MjData(g1_model)
    legs = [g1.JOINT_NAMES.index(name) for name in kin.joint_names]
    rng = np.random.default_rng(0)
    for _ in range(10):
        data.qpos[:] = 0.0
        data.qpos[3] = 1.0
        data.qpos[7:] = rng.uniform(-0.6, 0.6, g1.NUM_JOINTS)
        data.qvel[6:] = rng.normal(0.0, 2.0, g1.NUM_JOINTS)
        mujoco.mj_kinematics(g1_model, data)
        mujoco.mj_comPos(g1_model, data)
        kin.update(data.qpos[7:][legs], data.qvel[6:][legs])
        for side, name in enumerate(g1.ANKLE_BODIES):
            body = g1_model.body(name).id
            point = data.xpos[body] + data.xmat[body].reshape(3, 3) @ kin.contact_offset
            jac_pos, jac_rot = np.zeros((3, g1_model.nv)), np.zeros((3, g1_model.nv))
            mujoco.mj_jac(g1_model, data, jac_pos, jac_rot, point, body)
            dofs = [g1_model.jnt_dofadr[g1_model.joint(j).id] for j in kin.joint_names[6 * side : 6 * side + 6]]
            np.testing.assert_allclose(kin.foot_pos[side], point, atol=1e-9)  # the pelvis stands at the origin, unrotated
            np.testing.assert_allclose(kin.jac_pos[side], jac_pos[:, dofs], atol=1e-9)
            np.testing.assert_allclose(kin.jac_rot[side], jac_rot[:, dofs], atol=1e-9)
            np.testing.assert_allclose(kin.foot_vel[side], jac_pos @ data.qvel, atol=1e-9)


def test_an_orientation_the_reader_does_not_take_is_one_line(assets: Assets, tmp_path: Path) -> None:
    text = assets.g1_mjcf.read_text().replace('<body name="left_knee_link" pos', '<body name="left_knee_link" euler="0 0 0" pos', 1)
    mjcf = tmp_path / "g1.xml"
    mjcf.write_text(text)
    with pytest.raises(AssetError, match=r"body left_knee_link: orientation given as 'euler'") as error:
        LegKinematics.from_mjcf(mjcf)
    assert "\n" not in str(error.value)
