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
    `foot_pos` (2, 3) and `foot_vel` (2, 3) (J dq); `jac_pos` and `jac_rot` (2, 3, 6) are views of
    the last update's Jacobians. numpy's cost is per call, not per number, so both legs go through
    a dozen batched calls: every body's homogeneous transform in its parent in one product
    (Rodrigues, its terms precomputed), the transforms down the chains in three (a prefix scan),
    then the hinge axes, the levers and the Jacobian columns.
    """

    def __init__(self, chains: tuple[LegChain, LegChain], contact_offset: tuple[float, float, float] = SOLE_OFFSET) -> None:
        for chain in chains:
            if np.any(chain.joint_anchor != 0.0):
                raise AssetError(f"leg joints {chain.joints} have hinges away from their body's origin; the leg kinematics take them at it")
        self.chains = chains
        self.joint_names: tuple[str, ...] = chains[0].joints + chains[1].joints
        self.contact_offset = np.asarray(contact_offset, dtype=np.float64)
        # Arrays are (body, leg, ...): slices along the chain stay contiguous.
        body_rot = np.stack([c.body_rot for c in chains], axis=1)  # (6, 2, 3, 3)
        axis = np.stack([c.joint_axis for c in chains], axis=1)  # (6, 2, 3)
        skew = np.zeros((6, 2, 3, 3))
        skew[..., 0, 1], skew[..., 0, 2], skew[..., 1, 2] = -axis[..., 2], axis[..., 1], -axis[..., 0]
        skew -= np.swapaxes(skew, -1, -2)
        # A body's transform in its parent at hinge angle q is [Rb (I + sin q K + (1 - cos q) K^2), pb; 0 0 0 1]
        # (Rodrigues, the hinge at the body's origin): the row (1, sin q, cos q) times three 4x4 matrices.
        basis = np.zeros((6, 2, 3, 4, 4))
        basis[:, :, 0, :3, :3] = body_rot + body_rot @ skew @ skew
        basis[:, :, 0, :3, 3] = np.stack([c.body_pos for c in chains], axis=1)
        basis[:, :, 0, 3, 3] = 1.0
        basis[:, :, 1, :3, :3] = body_rot @ skew
        basis[:, :, 2, :3, :3] = -body_rot @ skew @ skew
        self._basis = basis.reshape(6, 2, 3, 16)
        self._coef = np.ones((6, 2, 1, 3))
        # The prefix scan (Hillis-Steele): _SCAN_PAD identities, then the six hinged bodies' transforms and the
        # contact point's (a translation in the ankle-roll link); three products of each entry with the one
        # 1, 2, 4 places up leave every entry the transform from the pelvis to it.
        self._scan = np.zeros((4, _SCAN_PAD + 7, 2, 4, 4))
        self._scan[...] = np.eye(4)
        self._scan[0, -1, :, :3, 3] = self.contact_offset
        self._local = self._scan[0, _SCAN_PAD : _SCAN_PAD + 6].reshape(6, 2, 1, 16)
        self._axis = np.zeros((6, 2, 4, 1))  # each hinge's axis in its body's frame (a direction: no translation)
        self._axis[:, :, :3, 0] = axis
        self._axes = np.zeros((6, 2, 4, 1))  # each hinge's axis in the pelvis frame
        self._lever = np.zeros((6, 2, 3))  # from each hinge to the foot
        self._outer = np.zeros((6, 2, 3, 3))
        self._columns = np.zeros((6, 2, 3))  # each hinge's column of the position Jacobian: axis x lever
        frames = self._scan[-1, _SCAN_PAD:]  # (7, 2, 4, 4): each body after its hinge, then the contact point
        self._hinges = frames[:6, :, :3, 3]  # a body's origin is its hinge
        self._after = frames[:6]
        self.foot_pos = frames[6, :, :3, 3]  # (2, 3), a view
        self.foot_vel = np.zeros((2, 3))
        # The views each update works on, made once: a view costs about as much as a small numpy call.
        self._sin, self._cos = self._coef[:, :, 0, 1], self._coef[:, :, 0, 2]
        self._scan_steps = [
            (self._scan[step, _SCAN_PAD - (1 << step) : -(1 << step)], self._scan[step, _SCAN_PAD:], self._scan[step + 1, _SCAN_PAD:])
            for step in range(3)
        ]
        self._axes_column = self._axes[..., :3, :]
        self._lever_row = self._lever[..., None, :]
        self._outer_flat = self._outer.reshape(6, 2, 9)
        self._columns_by_leg = np.swapaxes(self._columns, 0, 1)  # (2, 6, 3)
        self._foot_vel_row = self.foot_vel[:, None, :]

    @classmethod
    def from_mjcf(cls, mjcf: Path, contact_offset: tuple[float, float, float] = SOLE_OFFSET) -> LegKinematics:
        return cls(read_leg_chains(mjcf), contact_offset)

    @property
    def jac_pos(self) -> FloatArray:
        """(2, 3, 6): d foot_pos / d q per leg (a view of the last update)."""
        return np.transpose(self._columns, (1, 2, 0))

    @property
    def jac_rot(self) -> FloatArray:
        """(2, 3, 6): the foot's angular velocity per unit joint rate, per leg (a view of the last update)."""
        return np.transpose(self._axes[:, :, :3, 0], (1, 2, 0))

    def update(self, q: FloatArray, dq: FloatArray) -> None:
        """Forward kinematics and Jacobians of both legs at joint angles `q` (12), velocities from rates `dq` (12)."""
        angles = q.reshape(2, 6).T
        np.sin(angles, out=self._sin)
        np.cos(angles, out=self._cos)
        np.matmul(self._coef, self._basis, out=self._local)
        for parents, bodies, out in self._scan_steps:
            np.matmul(parents, bodies, out=out)
        np.matmul(self._after, self._axis, out=self._axes)
        np.subtract(self.foot_pos, self._hinges, out=self._lever)
        # axis x lever: the outer product of the two contracted with the permutation symbol.
        np.multiply(self._axes_column, self._lever_row, out=self._outer)
        np.matmul(self._outer_flat, _LEVI_CIVITA, out=self._columns)
        np.matmul(dq.reshape(2, 1, 6), self._columns_by_leg, out=self._foot_vel_row)


_SCAN_PAD = 4  # identities before the chain's seven transforms: the scan's largest step
# (a x b)_k = sum_ij eps_ijk a_i b_j: the permutation symbol, row i * 3 + j, column k.
_LEVI_CIVITA = np.array(
    [[0, 0, 0], [0, 0, 1], [0, -1, 0], [0, 0, -1], [0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, 0, 0]], dtype=np.float64
)
