"""A text plan executed on paper: an ideal robot, without physics.

The same `TextReference` (followers, scheduler, buffer, blends, resyncs) runs as in
simulation, with an ideal robot under it: its root moves exactly as the velocity command
says (what the locomotion policy under the `decoupled` tracker is asked for), its pelvis
height and joints are the plan's. It gives the composed plan alone (for comparing blended
against naive joins without the tracker in between) and a quick preview of a program's
timing. Taking the plan's own root as the robot's instead, a clause never arrived: the
plan's root answers the follower's slowest commands late, and drifted 0.4 m off a 1 m walk
in 11 s. No MuJoCo.
"""

from __future__ import annotations

import math

import numpy as np

from controller.commands.velocity import ZERO, VelocityCommand
from controller.reference.buffer import ReferenceSample
from controller.text.executor import TextReference
from hw import g1, quat
from hw.types import RobotState


def ideal_state(sample: ReferenceSample, pose: tuple[float, float, float], velocity: VelocityCommand, t: float) -> RobotState:
    """The robot at root `pose` (x, y, heading) moving at `velocity` (heading frame), with the plan's height and joints."""
    x, y, heading = pose
    c, s = math.cos(heading), math.sin(heading)
    q = sample.qpos
    return RobotState(
        time=t,
        joint_pos=np.array(q[g1.QPOS_JOINTS]),
        joint_vel=np.array(sample.joint_velocity),
        base_quat=quat.from_yaw(heading),
        base_ang_vel=np.array([0.0, 0.0, velocity.yaw_rate]),
        base_pos=np.array([x, y, q[2]]),
        base_lin_vel=np.array([c * velocity.vx - s * velocity.vy, s * velocity.vx + c * velocity.vy, 0.0]),
    )


def run_kinematic(reference: TextReference, rate_hz: float, max_seconds: float = 120.0, settle_s: float = 1.0) -> TextReference:
    """Tick `reference` at `rate_hz` (the tracker's: its policy's rate) from standing at the origin until its program is
    done (or `max_seconds`)."""
    dt = 1.0 / rate_hz
    pose, velocity = (0.0, 0.0, 0.0), ZERO
    qpos = np.array(g1.standing_qpos())
    state = RobotState(
        time=0.0, joint_pos=qpos[g1.QPOS_JOINTS], joint_vel=np.zeros(g1.NUM_JOINTS), base_quat=qpos[g1.QPOS_ROOT_QUAT],
        base_ang_vel=np.zeros(3), base_pos=qpos[g1.QPOS_ROOT_POS], base_lin_vel=np.zeros(3),
    )  # fmt: skip
    reference.start(state)
    for tick in range(round(max_seconds * rate_hz)):
        t = tick * dt
        x, y, heading = pose
        c, s = math.cos(heading), math.sin(heading)
        dx, dy = c * velocity.vx - s * velocity.vy, s * velocity.vx + c * velocity.vy
        pose = (x + dt * dx, y + dt * dy, heading + dt * velocity.yaw_rate)
        state = ideal_state(reference.planned.buffer.sample(t), pose, velocity, t)
        velocity = reference.window(state, ZERO).velocity
        if reference.finished_for(settle_s):
            break
    return reference
