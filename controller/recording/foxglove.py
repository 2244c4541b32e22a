"""Foxglove's standard messages, encoded: the joints, the world-to-pelvis transforms, a log line.

Quaternions come in the project's order (w, x, y, z) and go out in Foxglove's (x, y, z, w).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.JointState_pb2 import JointState
from foxglove_schemas_protobuf.JointStates_pb2 import JointStates
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf.timestamp_pb2 import Timestamp

WORLD = "world"
PELVIS = "pelvis"  # the base: by the simulator's truth where there is one, else as the controller saw it
PELVIS_ESTIMATE = "pelvis_estimate"  # the base as the state estimator saw it, where one runs beside a truth


def stamp(t: float) -> Timestamp:
    seconds = max(0, int(t))
    return Timestamp(seconds=seconds, nanos=min(999_999_999, max(0, round((t - seconds) * 1e9))))


def _quaternion(wxyz: Sequence[float]) -> Quaternion:
    w, x, y, z = wxyz
    return Quaternion(x=x, y=y, z=z, w=w)


def joint_states(t: float, names: Sequence[str], q: Sequence[float], dq: Sequence[float], tau: Sequence[float] | None) -> bytes:
    """`tau`: the measured torques (efforts), None where the robot does not report them."""
    message = JointStates()
    message.CopyFrom(_named(tuple(names)))  # the names once per run, copied in C; the values set per joint
    message.timestamp.CopyFrom(stamp(t))
    if tau is None:
        for joint, position, velocity in zip(message.joints, q, dq, strict=True):
            joint.position, joint.velocity = position, velocity
    else:
        for joint, position, velocity, effort in zip(message.joints, q, dq, tau, strict=True):
            joint.position, joint.velocity, joint.effort = position, velocity, effort
    return message.SerializeToString()


@functools.cache
def _named(names: tuple[str, ...]) -> JointStates:
    return JointStates(joints=[JointState(name=name) for name in names])


def frame_transforms(t: float, frames: Sequence[tuple[str, Sequence[float], Sequence[float]]]) -> bytes:
    """World -> each (child frame, position, quaternion w, x, y, z)."""
    transforms = []
    for child, (x, y, z), wxyz in frames:
        translation = Vector3(x=x, y=y, z=z)
        transforms.append(
            FrameTransform(
                timestamp=stamp(t), parent_frame_id=WORLD, child_frame_id=child, translation=translation, rotation=_quaternion(wxyz)
            )
        )
    return FrameTransforms(transforms=transforms).SerializeToString()


def log(t: float, level: int, name: str, text: str) -> bytes:
    return Log(timestamp=stamp(t), level=level, name=name, message=text).SerializeToString()  # type: ignore[arg-type]
