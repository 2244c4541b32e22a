"""A hardware config's joints over the G1 joint table (`hw.g1.G1_JOINTS`).

A hardware YAML states what is particular to its robot: buses, ids, directions, offsets, motor
models. A G1 joint's limits and bring-up gains come from the table unless the YAML states its
own: a gain may take any value, a limit may only narrow the table's (a bench rig that must not
swing a knee all the way). A limit wider than the table's, that is wider than the MJCF the
policies were trained on, is refused: one line naming the file, the joint and both values.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from hw.errors import ConfigError
from hw.g1 import G1_JOINT, G1Joint
from hw.types import LimitedJoint


def table_values(joint: G1Joint) -> dict[str, Any]:
    """A joint's entry in a hardware YAML as the table gives it (the keys both joint-map kinds share)."""
    return {
        "position_limits": list(joint.position_limits),
        "velocity_limit": joint.velocity_limit,
        "torque_limit": joint.effort_limit,
        "kp": joint.kp,
        "kd": joint.kd,
    }


def with_g1_joint_table(data: Any, every_joint: tuple[str, ...] = ()) -> Any:
    """The raw YAML with each G1 joint's unstated limits and gains filled in from the table.

    `every_joint`: joints the config may leave out altogether (a DDS config, which has nothing
    else to say of a joint); a bus config names each joint for its bus and id. Anything that is
    not a mapping is left for `from_dict` to report.
    """
    if not isinstance(data, dict):
        return data
    joints = data.get("joints")
    if joints is None and every_joint:
        joints = {}
    if not isinstance(joints, dict):
        return data
    names = [*(n for n in every_joint if n in G1_JOINT or n in joints), *(n for n in joints if n not in every_joint)]
    joints = {name: joints.get(name) for name in names}  # in `every_joint`'s order, the robot's
    filled = {
        name: {**table_values(G1_JOINT[name]), **(joint or {})} if isinstance(joint, dict | None) and name in G1_JOINT else joint
        for name, joint in joints.items()
    }
    return {**data, "joints": filled}


def check_within_g1_limits(joints: Mapping[str, LimitedJoint], source: str) -> None:
    """Refuse a G1 joint whose limits are wider than the table's (joints of other robots are not checked)."""
    for name, joint in joints.items():
        table = G1_JOINT.get(name)
        if table is None:
            continue
        (lo, hi), (table_lo, table_hi) = joint.position_limits, table.position_limits
        if lo < table_lo or hi > table_hi:
            _refuse(source, name, "position_limits", f"[{lo!r}, {hi!r}]", f"[{table_lo!r}, {table_hi!r}]", "from the MJCF")
        if joint.torque_limit > table.effort_limit:
            _refuse(source, name, "torque_limit", repr(joint.torque_limit), repr(table.effort_limit), "the MJCF's actuatorfrcrange")
        if joint.velocity_limit > table.velocity_limit:
            _refuse(source, name, "velocity_limit", repr(joint.velocity_limit), repr(table.velocity_limit), "COMMAND_VELOCITY_LIMIT")


def _refuse(source: str, name: str, key: str, value: str, table: str, origin: str) -> None:
    raise ConfigError(f"{source}: joints.{name}.{key} {value} is wider than the G1's {table} (hw/g1.py, {origin}): narrow it or remove it")
