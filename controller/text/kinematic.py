"""A text plan executed on paper: the robot is taken to be exactly where the plan is.

The same `TextReference` (followers, scheduler, buffer, blends) runs, but the robot's
state each tick is read from the reference itself: perfect tracking, no physics. It
gives the composed plan alone (for comparing blended against naive joins without the
tracker in between) and a quick preview of a program's timing. No MuJoCo.
"""

from __future__ import annotations

import numpy as np

from controller.inputs.base import ZERO
from controller.reference.buffer import ReferenceSample
from controller.text.executor import TextReference
from hw import g1, quat
from hw.types import RobotState

RATE_HZ = 50.0  # the tracker's rate: the reference is read at it


def state_from_sample(sample: ReferenceSample, t: float) -> RobotState:
    """The robot state that a perfectly tracked reference sample would be."""
    q = sample.qpos
    base_quat = np.array(q[g1.QPOS_ROOT_QUAT])
    gyro = quat.rotate_inverse_one(base_quat, np.array([0.0, 0.0, sample.yaw_rate]))
    return RobotState(
        time=t,
        joint_pos=np.array(q[g1.QPOS_JOINTS]),
        joint_vel=np.array(sample.joint_velocity),
        base_quat=base_quat,
        base_ang_vel=gyro,
        base_pos=np.array(q[g1.QPOS_ROOT_POS]),
        base_lin_vel=np.array(sample.root_velocity),
    )


def run_kinematic(reference: TextReference, max_seconds: float = 120.0, settle_s: float = 1.0) -> TextReference:
    """Tick `reference` at the tracker's rate from standing at the origin until its program is done (or `max_seconds`)."""
    qpos = np.array(g1.standing_qpos())
    state = RobotState(
        time=0.0, joint_pos=qpos[g1.QPOS_JOINTS], joint_vel=np.zeros(g1.NUM_JOINTS), base_quat=qpos[g1.QPOS_ROOT_QUAT],
        base_ang_vel=np.zeros(3), base_pos=qpos[g1.QPOS_ROOT_POS], base_lin_vel=np.zeros(3),
    )  # fmt: skip
    reference.start(state)
    ticks = round(max_seconds * RATE_HZ)
    for tick in range(ticks):
        t = tick / RATE_HZ
        state = state_from_sample(reference.planned.buffer.sample(t), t)
        reference.window(state, ZERO)
        if reference.finished_for(settle_s):
            break
    return reference
