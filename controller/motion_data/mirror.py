"""Left-right mirroring of G1 motion: the same motion seen in a mirror on the robot's x-z plane.

Left and right joints swap; roll and yaw joints (and the waist's) change sign, pitch joints,
knees and elbows keep theirs (the G1's left and right joints share their axes). The root's
lateral position negates and its orientation is reflected: quaternion (w, x, y, z) ->
(w, -x, y, -z), so heading and roll negate and pitch stays. Foot contacts swap. Mirroring
twice gives the motion back. Pure numpy: training augments imported clips with it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from hw import g1

FloatArray = NDArray[np.float64]

_NEGATED_PARTS = ("roll", "yaw")


def _joint_mirror() -> tuple[NDArray[np.int64], FloatArray]:
    """For each joint, the index of its mirror image and the sign it takes."""
    names = g1.JOINT_NAMES
    source = np.empty(len(names), dtype=np.int64)
    sign = np.ones(len(names))
    for i, name in enumerate(names):
        other = "right_" + name[5:] if name.startswith("left_") else "left_" + name[6:] if name.startswith("right_") else name
        source[i] = names.index(other)
        if any(f"_{part}_" in name for part in _NEGATED_PARTS):
            sign[i] = -1.0
    return source, sign


_JOINT_SOURCE, _JOINT_SIGN = _joint_mirror()


def mirror_qpos(qpos: FloatArray) -> FloatArray:
    """Mirrored frames [..., 36] (G1 `qpos`)."""
    q = np.asarray(qpos, dtype=np.float64)
    out = q.copy()
    pos, rot, joints = g1.QPOS_ROOT_POS, g1.QPOS_ROOT_QUAT, g1.QPOS_JOINTS
    out[..., pos.start + 1] = -q[..., pos.start + 1]
    out[..., rot.start + 1] = -q[..., rot.start + 1]  # x
    out[..., rot.start + 3] = -q[..., rot.start + 3]  # z
    out[..., joints] = q[..., joints][..., _JOINT_SOURCE] * _JOINT_SIGN
    return out


def mirror_contacts(contacts: NDArray[np.generic]) -> NDArray[np.generic]:
    """Foot contacts [..., 2] (left, right) of the mirrored motion."""
    return np.asarray(contacts)[..., ::-1].copy()
