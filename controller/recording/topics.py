"""The recording's topics: Foxglove's own schemas where one fits (joints, poses, the transform, the log), the project's for the rest.

Every message's log time is its tick's time on the run's clock, in nanoseconds. The per-tick
topics are protobuf (Foxglove's messages, and the `g1ctl` ones of `schemas`); the counters,
sampled once a second, are JSON (their fields differ between a bus robot and one over DDS).
"""

from __future__ import annotations

from typing import Any

from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.JointStates_pb2 import JointStates
from foxglove_schemas_protobuf.Log_pb2 import Log

from controller.recording.schemas import message
from controller.recording.sink import Topic


def _protobuf(name: str, cls: Any) -> Topic:
    return Topic(name, cls.DESCRIPTOR.full_name, proto=cls)


def _json(name: str, schema_name: str, description: str) -> Topic:
    return Topic(name, schema_name, json_schema={"title": schema_name, "description": description, "type": "object"})


JOINTS = _protobuf("/joints", JointStates)  # the joints as read: position, velocity, measured torque
TF = _protobuf("/tf", FrameTransforms)  # world -> pelvis (the truth where there is one, else the controller's view), -> pelvis_estimate
LOG = _protobuf("/log", Log)  # mode changes, faults, falls, an estimate given up

# The topics whose payloads the recorder queues as dicts, by its key for them.
PAYLOAD_TOPICS = {
    "state": _protobuf("/state", message("RobotState")),  # the base as read
    "estimate": _protobuf("/estimate", message("Estimate")),  # where an estimator runs
    "truth": _protobuf("/truth", message("Base")),  # where a simulator stands behind the robot
    "command": _protobuf("/command", message("JointCommand")),  # as sent
    "reference": _protobuf("/reference", message("ReferenceWindow")),  # the velocity and the plan window
    "input": _protobuf("/input", message("CommandSample")),
    "supervisor": _protobuf("/supervisor", message("Supervisor")),
    "tracking": _protobuf("/tracking", message("Tracking")),  # as the report judges it
    "bus": _json("/counters/bus", "g1ctl.BusCounters", "The hardware robot's counters: frames, drops, CRC errors, faults, lifecycle."),
    "estimator": _json("/counters/estimator", "g1ctl.EstimatorCounters", "The state estimator's updates and its fault."),
}
