"""The G1's leg kinematics, compiled (numba), its constants read once from the G1 MJCF (no MuJoCo on this path).

Each leg is a chain of six bodies from the pelvis to the ankle-roll link, one hinge each. The
MJCF gives every body's offset and orientation in its parent and every hinge's axis (inline or
from its default class); `leg_kinematics` (compiled, numba: a dozen 3x3 products are all there
is, and an interpreter would spend its time on the calls) turns joint angles and rates into
each foot's contact point in the pelvis frame, its velocity (J dq) and the Jacobians. The
numbers match MuJoCo's own kinematics to rounding (tests/controller/estimation/test_kinematics.py).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

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
    `foot_pos` (2, 3), `foot_vel` (2, 3) (J dq) and the Jacobians `jac_pos`, `jac_rot` (2, 3, 6).
    The work is `leg_kinematics`, compiled; the estimator calls it inside its own compiled step.
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
        skew = np.zeros((2, 6, 3, 3))  # K, the cross product with the axis
        skew[..., 0, 1], skew[..., 0, 2], skew[..., 1, 2] = -axis[..., 2], axis[..., 1], -axis[..., 0]
        skew -= np.swapaxes(skew, -1, -2)
        # A body's rotation in its parent at hinge angle q is Rb (I + sin q K + (1 - cos q) K^2) (Rodrigues, the hinge at
        # the body's origin): rest + sin q * sine + cos q * cosine.
        self.constants = LegConstants(
            rest=body_rot + body_rot @ skew @ skew,
            sine=body_rot @ skew,
            cosine=-body_rot @ skew @ skew,
            offset=np.stack([c.body_pos for c in chains]),
            axis=axis,
            contact=self.contact_offset,
        )
        self.foot_pos = np.zeros((2, 3))
        self.foot_vel = np.zeros((2, 3))
        self.jac_pos = np.zeros((2, 3, 6))  # d foot_pos / d q per leg
        self.jac_rot = np.zeros((2, 3, 6))  # the foot's angular velocity per unit joint rate, per leg
        self._in_order = np.arange(12)

    @classmethod
    def from_mjcf(cls, mjcf: Path, contact_offset: tuple[float, float, float] = SOLE_OFFSET) -> LegKinematics:
        return cls(read_leg_chains(mjcf), contact_offset)

    def update(self, q: FloatArray, dq: FloatArray) -> None:
        """Forward kinematics and Jacobians of both legs at joint angles `q` (12), velocities from rates `dq` (12)."""
        leg_kinematics(q, dq, self._in_order, self.constants, self.foot_pos, self.foot_vel, self.jac_pos, self.jac_rot)


class LegConstants(NamedTuple):
    """What `leg_kinematics` needs of the model, per leg (first axis) and body (second, hip to ankle)."""

    rest: FloatArray  # (2, 6, 3, 3): the body's rotation in its parent, the part independent of the hinge angle
    sine: FloatArray  # (2, 6, 3, 3): ... the part times its sine
    cosine: FloatArray  # (2, 6, 3, 3): ... the part times its cosine
    offset: FloatArray  # (2, 6, 3): the body's origin (its hinge) in its parent
    axis: FloatArray  # (2, 6, 3): the hinge's axis in the body's frame
    contact: FloatArray  # (3): the contact point in the ankle-roll link's frame


@njit(cache=True)
def leg_kinematics(
    q: FloatArray,
    dq: FloatArray,
    legs: NDArray[np.intp],
    model: LegConstants,
    foot_pos: FloatArray,
    foot_vel: FloatArray,
    jac_pos: FloatArray,
    jac_rot: FloatArray,
) -> None:
    """Both legs' contact points (2, 3), their velocities (2, 3) and Jacobians (2, 3, 6), in place, in the pelvis frame.

    `q`, `dq`: joint angles and rates; `legs` (12): where each leg joint sits in them (left hip pitch .. right ankle roll).
    """
    rot = np.empty((3, 3))
    turned = np.empty((3, 3))
    hinges = np.empty((6, 3))
    for leg in range(2):
        rot[:] = 0.0
        rot[0, 0] = rot[1, 1] = rot[2, 2] = 1.0
        t0 = t1 = t2 = 0.0
        for j in range(6):
            angle = q[legs[6 * leg + j]]
            s, c = math.sin(angle), math.cos(angle)
            o = model.offset[leg, j]
            t0 += rot[0, 0] * o[0] + rot[0, 1] * o[1] + rot[0, 2] * o[2]
            t1 += rot[1, 0] * o[0] + rot[1, 1] * o[1] + rot[1, 2] * o[2]
            t2 += rot[2, 0] * o[0] + rot[2, 1] * o[1] + rot[2, 2] * o[2]
            rest, sine, cosine = model.rest[leg, j], model.sine[leg, j], model.cosine[leg, j]
            for a in range(3):
                for b in range(3):
                    total = 0.0
                    for m in range(3):
                        total += rot[a, m] * (rest[m, b] + s * sine[m, b] + c * cosine[m, b])
                    turned[a, b] = total
            rot[:] = turned
            hinges[j, 0], hinges[j, 1], hinges[j, 2] = t0, t1, t2
            u = model.axis[leg, j]
            for a in range(3):
                jac_rot[leg, a, j] = rot[a, 0] * u[0] + rot[a, 1] * u[1] + rot[a, 2] * u[2]
        p = model.contact
        for a in range(3):
            foot_pos[leg, a] = (t0, t1, t2)[a] + rot[a, 0] * p[0] + rot[a, 1] * p[1] + rot[a, 2] * p[2]
            foot_vel[leg, a] = 0.0
        for j in range(6):  # each hinge's column of the position Jacobian: its axis x the lever from it to the foot
            lx, ly, lz = foot_pos[leg, 0] - hinges[j, 0], foot_pos[leg, 1] - hinges[j, 1], foot_pos[leg, 2] - hinges[j, 2]
            ax, ay, az = jac_rot[leg, 0, j], jac_rot[leg, 1, j], jac_rot[leg, 2, j]
            jac_pos[leg, 0, j] = ay * lz - az * ly
            jac_pos[leg, 1, j] = az * lx - ax * lz
            jac_pos[leg, 2, j] = ax * ly - ay * lx
            rate = dq[legs[6 * leg + j]]
            for a in range(3):
                foot_vel[leg, a] += jac_pos[leg, a, j] * rate
