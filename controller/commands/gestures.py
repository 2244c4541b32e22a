"""Procedural waist and arm gestures: their names, poses and motions, and the player that blends them in.

Each gesture is a target for the upper-body joints (waist and both arms), static or
oscillating, clamped inside the joint limits; `GesturePlayer` blends it over the policy's
own targets with a weight that rises and falls with a smoothstep. The recorded motion
dataset labels its frames with these gestures, and the planner's gesture library
(`reference.gestures`) turns them into keyframes.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from hw.errors import ConfigError
from hw.g1 import UPPER_BODY_JOINTS
from hw.types import FloatArray

# --- gestures ------------------------------------------------------------------------------------

# Index 0 is "no gesture": the policy's own arm and waist targets. A gesture's label in the
# dataset and in `GesturePlayer` is its index here.
GESTURE_LABELS: tuple[str, ...] = (
    "none",
    "wave",
    "raise_left",
    "raise_right",
    "raise_both",
    "reach",
    "point",
    "arms_crossed",
    "hands_on_hips",
    "wave_left",
    "wave_both",
)  # fmt: skip  ("wave" is the right hand's; names are only ever appended, so older datasets still load)

UPPER_JOINTS: tuple[str, ...] = UPPER_BODY_JOINTS  # waist (3), left arm (7), right arm (7)
BLEND_S = 0.5
_ARM = ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll", "wrist_pitch", "wrist_yaw")
_MIRRORED = {"shoulder_roll", "shoulder_yaw", "wrist_roll", "wrist_yaw", "waist_yaw", "waist_roll"}


def _arm(side: str, **angles: float) -> dict[str, float]:
    """Joint targets of one arm given as the left arm's angles; the right arm's are mirrored."""
    sign = -1.0 if side == "right" else 1.0
    out = {}
    for part, value in angles.items():
        if part not in _ARM:
            raise KeyError(part)
        out[f"{side}_{part}_joint"] = sign * value if part in _MIRRORED else value
    return out


# Static poses (rad), chosen with forward kinematics: no self-contact, within the joint
# limits, hands where the names say. Arm gains are low (kp 14), so the arms sag a little
# under gravity; the recorded qpos is what the robot did, not these targets.
# Raised: the upper arm out to the side and up, the forearm up ("hands up"). Until 2026-12-01 it
# was overhead by the front (shoulder pitch -2.8, the pose of the recorded datasets rec and rec2):
# standing, both arms raised that way pitched the robot 7 degrees forward and the locomotion
# policy, blind to its arms, ran after the lean and fell within 4 s (3 of 3 seeds); raised by the
# side it stood (3 of 3, 8 s). The roll is near its limit (2.25 rad) so that the arms, sagging under
# gravity on their low gains, still hold the palms 0.26-0.28 m above the shoulders (0.12-0.17 m at
# a roll of 2.0, under the gesture detector's 0.15 m).
_RAISED = {"shoulder_pitch": 0.0, "shoulder_roll": 2.15, "shoulder_yaw": 1.5, "elbow": 0.5, "wrist_roll": 0.0, "wrist_pitch": 0.0}
_WAVE = {"shoulder_pitch": -0.2, "shoulder_roll": 1.3, "shoulder_yaw": 1.4, "elbow": 0.0, "wrist_roll": 0.0, "wrist_pitch": 0.0}
_REACH = {"shoulder_pitch": -1.8, "shoulder_roll": 0.15, "shoulder_yaw": 0.0, "elbow": 1.35, "wrist_roll": 0.0, "wrist_pitch": 0.0}
_POINT = {"shoulder_pitch": -1.75, "shoulder_roll": 0.5, "shoulder_yaw": 0.0, "elbow": 1.5, "wrist_roll": 0.0, "wrist_pitch": 0.0}
_HIPS = {"shoulder_pitch": -0.1, "shoulder_roll": 1.16, "shoulder_yaw": -1.81, "elbow": -0.23, "wrist_roll": 0.0, "wrist_pitch": 0.0}
POSES: dict[str, dict[str, float]] = {
    "wave": _arm("right", **_WAVE),
    "wave_left": _arm("left", **_WAVE),
    "wave_both": {**_arm("left", **_WAVE), **_arm("right", **_WAVE)},
    "raise_left": _arm("left", **_RAISED),
    "raise_right": _arm("right", **_RAISED),
    "raise_both": {**_arm("left", **_RAISED), **_arm("right", **_RAISED)},
    "reach": _arm("right", **_REACH),
    "point": {**_arm("right", **_POINT), "waist_yaw_joint": -0.15},
    "arms_crossed": {  # left forearm above the right one
        **_arm("left", shoulder_pitch=-0.98, shoulder_roll=-0.16, shoulder_yaw=-1.26, elbow=0.4, wrist_roll=0.0, wrist_pitch=0.0),
        **_arm("right", shoulder_pitch=-0.6, shoulder_roll=-0.17, shoulder_yaw=-1.05, elbow=0.75, wrist_roll=0.0, wrist_pitch=0.0),
    },
    "hands_on_hips": {**_arm("left", **_HIPS), **_arm("right", **_HIPS)},
}
# Periodic parts: joint -> (amplitude rad, frequency Hz).
MOTIONS: dict[str, dict[str, tuple[float, float]]] = {
    "wave": {"right_elbow_joint": (0.4, 1.5)},
    "wave_left": {"left_elbow_joint": (0.4, 1.5)},
    "wave_both": {"left_elbow_joint": (0.4, 1.5), "right_elbow_joint": (0.4, 1.5)},
    "reach": {"right_shoulder_pitch_joint": (0.12, 0.4), "right_elbow_joint": (0.12, 0.4)},
    "point": {"waist_yaw_joint": (0.08, 0.3)},
}
# Joints that move in a part of the blend only, so that hands clear the thighs and each
# other on the way: joint -> (a, b), the joint's own weight rises from 0 to 1 while the
# gesture's weight goes from a to b (default 0 to 1).
PHASES: dict[str, dict[str, tuple[float, float]]] = {
    "hands_on_hips": {
        **{f"{s}_{part}_joint": (0.0, 0.4) for s in ("left", "right") for part in ("shoulder_roll", "elbow")},
        **{f"{s}_shoulder_yaw_joint": (0.4, 1.0) for s in ("left", "right")},
    },
    "arms_crossed": {f"right_{part}_joint": (0.3, 1.0) for part in _ARM},
}


def smoothstep(x: float) -> float:
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


class GesturePlayer:
    """Upper-body joint targets of each gesture over time, blended with the policy's targets."""

    def __init__(self, joint_names: tuple[str, ...], lower: FloatArray, upper: FloatArray, margin: float = 0.05) -> None:
        self._index = np.array([joint_names.index(j) for j in UPPER_JOINTS])
        lo, hi = lower[self._index] + margin, upper[self._index] - margin
        self._targets: list[FloatArray] = [np.zeros(len(UPPER_JOINTS))]
        self._masks: list[NDArray[np.bool_]] = [np.zeros(len(UPPER_JOINTS), dtype=bool)]
        self._motions: list[list[tuple[int, float, float]]] = [[]]
        self._phases: list[tuple[FloatArray, FloatArray]] = [(np.zeros(len(UPPER_JOINTS)), np.ones(len(UPPER_JOINTS)))]
        for name in GESTURE_LABELS[1:]:
            pose = POSES[name]
            target = np.zeros(len(UPPER_JOINTS))
            mask = np.zeros(len(UPPER_JOINTS), dtype=bool)
            for joint, value in pose.items():
                k = UPPER_JOINTS.index(joint)
                target[k], mask[k] = value, True
            motions = [(UPPER_JOINTS.index(j), a, f) for j, (a, f) in MOTIONS.get(name, {}).items()]
            for k, amplitude, _ in motions:
                if not lo[k] <= target[k] - amplitude and target[k] + amplitude <= hi[k]:
                    raise ConfigError(f"gesture '{name}' moves {UPPER_JOINTS[k]} past its joint limits")
            outside = mask & ((target < lo) | (target > hi))
            if outside.any():
                raise ConfigError(f"gesture '{name}' puts {[UPPER_JOINTS[k] for k in np.flatnonzero(outside)]} past their joint limits")
            a, b = np.zeros(len(UPPER_JOINTS)), np.ones(len(UPPER_JOINTS))
            for joint, (start, stop) in PHASES.get(name, {}).items():
                a[UPPER_JOINTS.index(joint)], b[UPPER_JOINTS.index(joint)] = start, stop
            self._targets.append(target)
            self._masks.append(mask)
            self._motions.append(motions)
            self._phases.append((a, b))

    @property
    def index(self) -> NDArray[np.int64]:
        """Robot joint indices of `UPPER_JOINTS`."""
        return self._index

    def joint_weights(self, gesture: int, weight: float) -> FloatArray:
        """How far each upper-body joint has moved to the gesture's target (0: policy, 1: gesture) at blend `weight`."""
        a, b = self._phases[gesture]
        return np.where(self._masks[gesture], np.clip((weight - a) / (b - a), 0.0, 1.0), 0.0)

    def apply(self, q: FloatArray, gesture: int, weight: float, tau: float) -> FloatArray:
        """`q` (the policy's targets, robot joint order) with gesture `gesture` blended in at `weight`, `tau` s into it."""
        if gesture == 0 or weight <= 0.0:
            return q
        target = self._targets[gesture].copy()
        for k, amplitude, freq in self._motions[gesture]:
            target[k] += amplitude * math.sin(2.0 * math.pi * freq * tau)
        weights = self.joint_weights(gesture, weight)
        out = q.copy()
        current = out[self._index]
        out[self._index] = current + weights * (target - current)
        return out
