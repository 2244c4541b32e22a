"""`g1ctl log replay`: a video of a recording, rendered in MuJoCo from the recorded joint and base states.

Each tick puts the G1 model where the recording says it was (`SimRobot.mirror`: the joints read,
the base pose by the simulator's truth where there was one, else as the controller saw it) and
hands it to the same `VideoRecorder` that `g1ctl sim --video` uses, with the plan of that tick
as its ghost and the time and the mode as its caption. Offline only: it imports MuJoCo.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from controller.assets import ensure_assets
from controller.recording import topics
from controller.recording.foxglove import PELVIS
from controller.recording.reader import Recording, read_recording
from hw import g1
from hw.errors import ConfigError


def replay_video(path: Path, video: Path, fps: int = 20, assets_dir: str | None = None) -> tuple[Recording, int]:
    """Render `path` into `video` (.mp4 or .gif); the recording as read and the frames written."""
    from sim.render import VideoRecorder  # noqa: PLC0415 - MuJoCo: after the caller chose the OpenGL backend
    from sim.robot import SimRobot  # noqa: PLC0415
    from sim.world import build_model  # noqa: PLC0415

    reference, supervisor = topics.PAYLOAD_TOPICS["reference"], topics.PAYLOAD_TOPICS["supervisor"]
    keep = {topics.JOINTS.name, topics.TF.name, reference.name, supervisor.name}
    recording = read_recording(path, keep=keep)
    joints = recording.decoded(topics.JOINTS)
    if not joints:
        raise ConfigError(f"{path}: no {topics.JOINTS.name} messages: nothing to replay (is it a g1ctl recording, made with --record?)")
    poses = {
        t: transform
        for t, message in recording.decoded(topics.TF)
        for transform in message.transforms
        if transform.child_frame_id == PELVIS
    }
    if not poses:
        raise ConfigError(f"{path}: no base pose recorded (world -> {PELVIS} on {topics.TF.name}): the robot cannot be placed")
    plans = {t: list(message.plan.qpos) for t, message in recording.decoded(reference) if message.HasField("plan")}
    modes = {t: message.mode for t, message in recording.decoded(supervisor)}
    names = [joint.name for joint in joints[0][1].joints]
    missing = sorted(set(g1.JOINT_NAMES) - set(names))
    if missing:
        raise ConfigError(f"{path}: the recorded joints lack {', '.join(missing)}: not a whole G1 to replay")
    order = [names.index(name) for name in g1.JOINT_NAMES]
    robot = SimRobot(build_model(ensure_assets(assets_dir).g1_mjcf))
    qpos, qvel = np.zeros(robot.model.nq), np.zeros(robot.model.nv)
    start = joints[0][0]
    try:
        with VideoRecorder(robot.model, video, fps=fps) as recorder:
            for t, message in joints:
                pose = poses.get(t)
                if pose is None:
                    continue  # a tick whose base pose was not recorded (dropped)
                position, orientation = pose.translation, pose.rotation
                qpos[g1.QPOS_ROOT_POS] = (position.x, position.y, position.z)
                qpos[g1.QPOS_ROOT_QUAT] = (orientation.w, orientation.x, orientation.y, orientation.z)
                positions = [joint.position for joint in message.joints]
                qpos[g1.QPOS_JOINTS] = [positions[i] for i in order]
                robot.mirror(qpos, qvel, t - start)
                plan = plans.get(t)
                recorder.maybe_capture(robot.data, np.asarray(plan) if plan is not None else None, f"{t:7.2f} s  {modes.get(t, '')}")
            frames = recorder.frames
    finally:
        robot.close()
    return recording, frames
