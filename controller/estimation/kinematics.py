"""The G1's leg kinematics in numpy, its constants read once from the G1 MJCF (no MuJoCo on this path).

Each leg is a chain of six bodies from the pelvis to the ankle-roll link, one hinge each. The
MJCF gives every body's offset and orientation in its parent and every hinge's axis (inline or
from its default class); `LegKinematics` turns joint angles and rates into each foot's contact
point in the pelvis frame, its velocity (J dq) and the Jacobians. The numbers match MuJoCo's own
kinematics to rounding (tests/controller/estimation/test_kinematics.py).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hw.errors import AssetError
from hw.g1 import ROOT_BODY
from hw.types import FloatArray

SIDES = ("left", "right")
# The six hinges of a leg, hip to ankle, by the name the MJCF gives them after the side's prefix.
LEG_JOINTS = ("hip_pitch_joint", "hip_roll_joint", "hip_yaw_joint", "knee_joint", "ankle_pitch_joint", "ankle_roll_joint")
FOOT_BODY = "ankle_roll_link"
# The contact point in the ankle-roll link's frame: under its origin, at the sole. The foot's
# collision capsules lie 0.025 m below the origin with a 0.01 m radius; the sole point drifts less
# than the ankle's origin when the foot rolls (figures in docs/estimation.md).
SOLE_OFFSET = (0.0, 0.0, -0.035)


@dataclass(frozen=True)
class LegChain:
    """One leg's constants: per body (hip to ankle) its offset and rotation in its parent, its hinge's axis and anchor."""

    joints: tuple[str, ...]
    body_pos: FloatArray  # (6, 3)
    body_rot: FloatArray  # (6, 3, 3)
    joint_axis: FloatArray  # (6, 3), unit, in the body's frame
    joint_anchor: FloatArray  # (6, 3), in the body's frame


def _floats(text: str, n: int, where: str) -> FloatArray:
    values = np.array([float(v) for v in text.split()])
    if values.shape != (n,):
        raise AssetError(f"{where}: expected {n} numbers, got '{text}'")
    return values


def _quat_matrix(q: FloatArray) -> FloatArray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _joint_defaults(root: ET.Element) -> dict[str, dict[str, str]]:
    """Default class -> the joint attributes it sets, each class holding what its ancestors set too."""
    found: dict[str, dict[str, str]] = {}

    def walk(element: ET.Element, inherited: dict[str, str]) -> None:
        joint = element.find("joint")
        own = inherited | (dict(joint.attrib) if joint is not None else {})
        found[element.get("class", "main")] = own
        for child in element.findall("default"):
            walk(child, own)

    for top in root.findall("default"):
        walk(top, {})
    return found


def read_leg_chains(mjcf: Path) -> tuple[LegChain, LegChain]:
    """The left and right leg chains of the G1 MJCF at `mjcf`."""
    try:
        root = ET.parse(mjcf).getroot()
    except (OSError, ET.ParseError) as exc:
        raise AssetError(f"cannot read the G1 model {mjcf} ({exc}); run 'g1ctl assets fetch' to restore it") from exc
    defaults = _joint_defaults(root)
    parents = {child: parent for parent in root.iter() for child in parent}
    bodies = {b.get("name"): b for b in root.iter("body")}
    if ROOT_BODY not in bodies:
        raise AssetError(f"{mjcf}: no body '{ROOT_BODY}'")
    return (_chain(mjcf, "left", bodies, parents, defaults), _chain(mjcf, "right", bodies, parents, defaults))


def _chain(
    mjcf: Path, side: str, bodies: dict[str | None, ET.Element], parents: dict[ET.Element, ET.Element], defaults: dict[str, dict[str, str]]
) -> LegChain:
    foot = bodies.get(f"{side}_{FOOT_BODY}")
    if foot is None:
        raise AssetError(f"{mjcf}: no body '{side}_{FOOT_BODY}'")
    path = [foot]
    while path[-1].get("name") != ROOT_BODY:
        path.append(parents[path[-1]])
    path = path[-2::-1]  # the bodies below the pelvis, hip first
    names = tuple(f"{side}_{j}" for j in LEG_JOINTS)
    if len(path) != len(names):
        raise AssetError(f"{mjcf}: {len(path)} bodies from the pelvis to {side}_{FOOT_BODY}, expected {len(names)}")
    pos, rot, axis, anchor = [], [], [], []
    for body, name in zip(path, names, strict=True):
        where = f"{mjcf}: body {body.get('name')}"
        unsupported = [a for a in ("euler", "axisangle", "xyaxes", "zaxis") if a in body.attrib]
        if unsupported:
            raise AssetError(f"{where}: orientation given as '{unsupported[0]}'; the leg kinematics read 'quat' only")
        pos.append(_floats(body.get("pos", "0 0 0"), 3, where))
        rot.append(_quat_matrix(_floats(body.get("quat", "1 0 0 0"), 4, where)))
        joints = body.findall("joint")
        if len(joints) != 1 or joints[0].get("name") != name:
            raise AssetError(f"{where}: expected one joint '{name}', found {[j.get('name') for j in joints]}")
        attrs = _joint_attributes(joints[0], body, parents, defaults)
        if attrs.get("type", "hinge") != "hinge":
            raise AssetError(f"{where}: joint {name} is a {attrs['type']}, the leg kinematics take hinges")
        a = _floats(attrs.get("axis", "0 0 1"), 3, f"{where} joint {name} axis")
        axis.append(a / np.linalg.norm(a))
        anchor.append(_floats(attrs.get("pos", "0 0 0"), 3, f"{where} joint {name} pos"))
    return LegChain(names, np.array(pos), np.array(rot), np.array(axis), np.array(anchor))


def _joint_attributes(
    joint: ET.Element, body: ET.Element, parents: dict[ET.Element, ET.Element], defaults: dict[str, dict[str, str]]
) -> dict[str, str]:
    """A joint's attributes with its default class's filled in: its own `class`, else the nearest body's `childclass`."""
    cls = joint.get("class")
    element: ET.Element | None = body
    while cls is None and element is not None:
        cls = element.get("childclass")
        element = parents.get(element)
    return defaults.get(cls or "main", defaults.get("main", {})) | dict(joint.attrib)


class LegKinematics:
    """Both legs at once: foot contact points in the pelvis frame, their velocities and Jacobians.

    `update(q, dq)` takes the 12 leg joints (left hip pitch .. ankle roll, then right) and fills
    `foot_pos` (2, 3), `foot_vel` (2, 3) (J dq), `jac_pos` and `jac_rot` (2, 3, 6). The chain is
    evaluated for all twelve hinges at once (one batched Rodrigues formula, six matrix products
    down each leg): numpy's cost is per call, not per number.
    """

    def __init__(self, chains: tuple[LegChain, LegChain], contact_offset: tuple[float, float, float] = SOLE_OFFSET) -> None:
        for chain in chains:
            if np.any(chain.joint_anchor != 0.0):
                raise AssetError(f"leg joints {chain.joints} have hinges away from their body's origin; the leg kinematics take them at it")
        self.chains = chains
        self.joint_names: tuple[str, ...] = chains[0].joints + chains[1].joints
        self.contact_offset = np.asarray(contact_offset, dtype=np.float64)
        body_rot = np.stack([c.body_rot for c in chains])  # (2, 6, 3, 3)
        axis = np.stack([c.joint_axis for c in chains])  # (2, 6, 3)
        skew = np.zeros((2, 6, 3, 3))
        skew[..., 0, 1], skew[..., 0, 2], skew[..., 1, 2] = -axis[..., 2], axis[..., 1], -axis[..., 0]
        skew -= np.swapaxes(skew, -1, -2)
        # Each body's rotation in its parent at hinge angle q is Rb (I + sin q K + (1 - cos q) K^2) (Rodrigues):
        # the row (1, sin q, 1 - cos q) times the three matrices, flattened, is one batched product.
        self._basis = np.stack([body_rot, body_rot @ skew, body_rot @ skew @ skew], axis=2).reshape(2, 6, 3, 9)
        self._coef = np.ones((2, 6, 1, 3))
        self._local = np.zeros((2, 6, 1, 9))
        self._body_pos = np.stack([c.body_pos for c in chains])[..., None]  # (2, 6, 3, 1)
        self._axis_in_parent = body_rot @ axis[..., None]  # (2, 6, 3, 1): the hinge axis in the parent's frame
        self._frames = np.zeros((2, 7, 3, 3))  # cumulative rotations: the pelvis, then each body after its hinge
        self._frames[:, 0] = np.eye(3)
        self.foot_pos = np.zeros((2, 3))
        self.foot_vel = np.zeros((2, 3))
        self.jac_pos = np.zeros((2, 3, 6))
        self.jac_rot = np.zeros((2, 3, 6))

    @classmethod
    def from_mjcf(cls, mjcf: Path, contact_offset: tuple[float, float, float] = SOLE_OFFSET) -> LegKinematics:
        return cls(read_leg_chains(mjcf), contact_offset)

    def update(self, q: FloatArray, dq: FloatArray) -> None:
        """Forward kinematics and Jacobians of both legs at joint angles `q` (12), velocities from rates `dq` (12)."""
        angles = q.reshape(2, 6)
        coef, frames = self._coef, self._frames
        np.sin(angles, out=coef[:, :, 0, 1])
        np.cos(angles, out=coef[:, :, 0, 2])
        np.subtract(1.0, coef[:, :, 0, 2], out=coef[:, :, 0, 2])
        local = np.matmul(coef, self._basis, out=self._local).reshape(2, 6, 3, 3)
        for i in range(6):
            np.matmul(frames[:, i], local[:, i], out=frames[:, i + 1])
        before = frames[:, :6]  # each body's parent frame, in the pelvis frame
        hinges = np.cumsum(before @ self._body_pos, axis=1)[..., 0]  # (2, 6, 3): each hinge's position
        axes = (before @ self._axis_in_parent)[..., 0]  # (2, 6, 3): each hinge's axis
        foot = hinges[:, 5] + frames[:, 6] @ self.contact_offset
        columns = _cross(axes, foot[:, None, :] - hinges)  # (2, 6, 3): each hinge's column of the position Jacobian
        self.foot_pos[:] = foot
        self.jac_rot[:] = np.swapaxes(axes, 1, 2)
        self.jac_pos[:] = np.swapaxes(columns, 1, 2)
        np.matmul(dq.reshape(2, 1, 6), columns, out=self.foot_vel[:, None, :])


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """a x b over the last axis; several times cheaper than `np.cross` on small arrays."""
    a2, b2 = np.concatenate((a, a), axis=-1), np.concatenate((b, b), axis=-1)
    return a2[..., 1:4] * b2[..., 2:5] - a2[..., 2:5] * b2[..., 1:4]
