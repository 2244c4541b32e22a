"""The recording's own protobuf messages (package `g1ctl`), declared here and built at import: no .proto file, no protoc.

Per-tick topics are protobuf, not JSON: packing a few hundred doubles is about twenty times
cheaper, and the recorder's writer thread shares the interpreter with the control loop. The
schemas go into the file (a `FileDescriptorSet` per channel), so Foxglove and any MCAP tool
decode them without this code. Field types: `double`, `bool`, `string`, a list of them (`[]`),
or another message of this file. Arrays follow the robot's joint order (the file's `run`
metadata); quaternions are w, x, y, z.
"""

from __future__ import annotations

from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

PACKAGE = "g1ctl"

MESSAGES: dict[str, dict[str, str]] = {
    "Velocity": {"vx": "double", "vy": "double", "yaw_rate": "double"},  # m/s in the heading frame; rad/s
    "RobotState": {  # the robot's base as read (the joints are on foxglove.JointStates)
        "time": "double", "base_quat": "double[]", "base_ang_vel": "double[]", "imu_accel": "double[]", "base_pos": "double[]",
        "base_lin_vel": "double[]", "has_base_position": "bool",
    },
    "Base": {"base_pos": "double[]", "base_lin_vel": "double[]", "base_quat": "double[]"},  # the simulator's truth
    "Estimate": {  # the state estimator's output: what the controller saw of the base
        "base_pos": "double[]", "base_lin_vel": "double[]", "base_quat": "double[]", "contacts": "bool[]", "position_std": "double",
    },
    "JointCommand": {"q": "double[]", "dq": "double[]", "kp": "double[]", "kd": "double[]", "tau_ff": "double[]"},
    "ReferenceSample": {
        "time": "double", "qpos": "double[]", "root_velocity": "double[]", "yaw_rate": "double", "joint_velocity": "double[]",
        "held": "bool",
    },
    "ReferenceWindow": {
        "time": "double", "velocity": "Velocity", "path_velocity": "Velocity", "plan": "ReferenceSample", "ahead": "ReferenceSample",
    },
    "CommandSample": {"velocity": "Velocity", "start": "bool", "stop": "bool", "estop": "bool", "alive": "bool", "gesture": "string"},
    "Supervisor": {"mode": "string", "reason": "string", "fault": "string"},  # "" for no reason, no fault
    "Tracking": {"commanded": "Velocity", "measured": "Velocity"},  # measured: absent on a tick that gave none
}  # fmt: skip

_SCALARS = {
    "double": descriptor_pb2.FieldDescriptorProto.TYPE_DOUBLE,
    "bool": descriptor_pb2.FieldDescriptorProto.TYPE_BOOL,
    "string": descriptor_pb2.FieldDescriptorProto.TYPE_STRING,
}


def _file() -> descriptor_pb2.FileDescriptorProto:
    field = descriptor_pb2.FieldDescriptorProto
    proto = descriptor_pb2.FileDescriptorProto(name=f"{PACKAGE}/recording.proto", package=PACKAGE, syntax="proto3")
    for name, fields in MESSAGES.items():
        message = proto.message_type.add(name=name)
        for number, (field_name, kind) in enumerate(fields.items(), start=1):
            repeated = kind.endswith("[]")
            base = kind.removesuffix("[]")
            label = field.LABEL_REPEATED if repeated else field.LABEL_OPTIONAL
            if base in _SCALARS:
                message.field.add(name=field_name, number=number, type=_SCALARS[base], label=label)
            elif base in MESSAGES:
                message.field.add(name=field_name, number=number, type=field.TYPE_MESSAGE, type_name=f".{PACKAGE}.{base}", label=label)
            else:
                raise ValueError(f"{name}.{field_name}: unknown field type {kind!r}")
    return proto


_POOL = descriptor_pool.DescriptorPool()
_POOL.Add(_file())


def message(name: str) -> Any:
    """The message class `g1ctl.<name>`."""
    return message_factory.GetMessageClass(_POOL.FindMessageTypeByName(f"{PACKAGE}.{name}"))
