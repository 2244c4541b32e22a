"""Forward kinematics of the G1 for motion clips: body positions and rotations per frame.

Used by the in-betweening benchmark (global position and rotation errors, foot skate) and
by clip import (foot contact labels). Only `mj_kinematics` runs: no dynamics, no contacts.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from hw.errors import ConfigError
from sim.world import build_model

FloatArray = NDArray[np.float64]

FOOT_CONTACT_BODIES = ("left_foot_contact_point", "right_foot_contact_point")  # frames at the soles, no geoms
CONTACT_HEIGHT_M = 0.05  # a foot whose contact point is lower than this, in both adjacent frames, is in contact


class G1Kinematics:
    """Evaluates every body's world pose for a sequence of G1 `qpos` frames [T, 36]."""

    def __init__(self, mjcf_path: Path) -> None:
        self.model = build_model(mjcf_path)
        self._data = mujoco.MjData(self.model)
        # Body 0 is the world; the foot contact points are frames, not links.
        names = (self.model.body(i).name for i in range(1, self.model.nbody))
        self.body_names = tuple(name for name in names if name not in FOOT_CONTACT_BODIES)
        self._bodies = np.array([self.model.body(n).id for n in self.body_names])
        self._feet = np.array([self.model.body(n).id for n in FOOT_CONTACT_BODIES])

    def forward(self, qpos: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Returns link positions [T, B, 3], link quaternions w,x,y,z [T, B, 4] and foot contact points [T, 2, 3]."""
        qpos = np.asarray(qpos, dtype=np.float64)
        if qpos.ndim != 2 or qpos.shape[1] != self.model.nq:
            raise ConfigError(f"motion frames must be [T, {self.model.nq}] G1 qpos, got shape {qpos.shape}")
        n = len(qpos)
        pos = np.empty((n, len(self._bodies), 3))
        quat = np.empty((n, len(self._bodies), 4))
        feet = np.empty((n, 2, 3))
        for t in range(n):
            self._data.qpos[:] = qpos[t]
            mujoco.mj_kinematics(self.model, self._data)
            pos[t] = self._data.xpos[self._bodies]
            quat[t] = self._data.xquat[self._bodies]
            feet[t] = self._data.xpos[self._feet]
        return pos, quat, feet


def foot_contacts(feet: FloatArray, height: float = CONTACT_HEIGHT_M) -> NDArray[np.bool_]:
    """Contact labels [T, 2] from foot contact points [T, 2, 3]: below `height` in this frame and the next."""
    low = feet[..., 2] < height
    contact = low.copy()
    contact[:-1] &= low[1:]
    return contact


LEG_LINKS = ("hip_pitch_link", "hip_roll_link", "hip_yaw_link", "knee_link", "ankle_pitch_link", "ankle_roll_link")


def leg_chain_specs(model: mujoco.MjModel) -> list[dict[str, list[list[float]] | list[float]]]:
    """Left and right leg chains as plain lists (link offsets, fixed rotations, joint axes, sole point) for the planner's spec."""
    specs = []
    for side in ("left", "right"):
        links = [model.body(f"{side}_{name}") for name in LEG_LINKS]
        joints = [int(np.flatnonzero(model.jnt_bodyid == link.id)[0]) for link in links]
        if any(model.jnt_pos[j].any() for j in joints):
            raise ConfigError("the planner's leg chains assume each leg joint sits at its link's origin")
        specs.append(
            {
                "offsets": [link.pos.tolist() for link in links],
                "quats": [link.quat.tolist() for link in links],
                "axes": [model.jnt_axis[j].tolist() for j in joints],
                "sole": model.body(f"{side}_foot_contact_point").pos.tolist(),
            }
        )
    return specs
