"""Upper-body gestures as arm keyframes of a plan request: the style library.

A gesture (wave, raise_both, point, ...) is the motion dataset's procedural gesture
(`commands.gestures`: a target pose per gesture, a sinusoid on the moving ones, blended
in and out with a smoothstep), here turned into pose keyframes on the arm joints of each
plan, so the planner layers it on whatever the legs do. Only the arms the gesture moves
are constrained: the other arm keeps the planner's own swing, and the waist stays with the
locomotion policy, which balances with it (the decoupled tracker never executes a planned
waist angle; point's waist yaw is left out for that reason).

Keyframes are dense: between constraints the planner's anchor curve is a straight line,
and a plan is replaced every 0.1 s, so only its first frames are ever executed. A
gesture's spacing keeps the straight lines within `tolerance` of its sinusoid. Measured on
`walk_and_wave` (planner in the loop, seed 0): with a keyframe every 12 frames the planned
arms were 0.088 rad from the gesture on average (the wave flattened), every 4 frames (2 for
the wave) 0.005 rad; the arms' tracking error was the same either way (0.057-0.058).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from controller.commands.gestures import BLEND_S, GESTURE_LABELS, MOTIONS, GesturePlayer, smoothstep
from controller.planner.request import FPS, BoolArray, Keyframe
from hw import g1
from hw.errors import ConfigError
from hw.types import FloatArray

NONE_NAMES = ("", "none")  # no gesture: the sample's "" or the dataset's "none"


@dataclass(frozen=True)
class GestureConfig:
    spacing_frames: int = 4  # an arm keyframe every this many plan frames (at most), counted back from the last
    tolerance: float = 0.02  # rad: straight lines between a moving gesture's keyframes stay this close to its sinusoid
    blend_s: float = BLEND_S  # blend in after a gesture starts, out after it ends (the dataset's 0.5 s)
    base: tuple[float, ...] = field(default_factory=lambda: tuple(g1.default_joint_vector()))  # arms blend from and back to this

    def __post_init__(self) -> None:
        if self.spacing_frames < 1:
            raise ConfigError(f"gesture spacing_frames must be at least 1, got {self.spacing_frames}")
        if self.tolerance <= 0 or self.blend_s <= 0:
            raise ConfigError(f"gesture tolerance and blend_s must be positive, got {self.tolerance} and {self.blend_s}")
        if len(self.base) != g1.NUM_JOINTS:
            raise ConfigError(f"gesture base pose must have {g1.NUM_JOINTS} joint angles, got {len(self.base)}")


@dataclass(frozen=True)
class Gesture:
    """A gesture in force from run time `start` to `end` (inf while it lasts): blended in after start, out after end."""

    name: str
    start: float
    end: float = math.inf

    def weight(self, t: float, blend_s: float) -> float:
        """How far the arms have gone to the gesture at run time `t` (0: base pose, 1: the gesture)."""
        rise = smoothstep((t - self.start) / blend_s)
        return min(rise, 1.0 - smoothstep((t - self.end) / blend_s)) if t > self.end else rise

    def alive(self, t: float, blend_s: float) -> bool:
        """Still shaping the arms at `t` (not yet fully blended out)."""
        return self.start <= t + 1e-9 and t < self.end + blend_s


@dataclass(frozen=True, eq=False)
class GestureStyle:
    """One entry of the library: the dataset gesture it plays, the arm joints it moves, its keyframe spacing."""

    name: str
    index: int  # in commands.gestures.GESTURE_LABELS, as GesturePlayer numbers them
    arms: BoolArray  # [29]: the arm joints the gesture moves
    spacing_frames: int


class GestureLibrary:
    """Gesture names -> arm angles over time and the keyframes that put them into a plan."""

    def __init__(self, cfg: GestureConfig = GestureConfig()) -> None:
        self.cfg = cfg
        # Unbounded limits: the player checks each gesture against the limits it is given, and the
        # gestures were checked against the MJCF's when the dataset was recorded (its tests do);
        # the scheduler clamps every plan to the robot's limits.
        unbounded = np.full(g1.NUM_JOINTS, np.inf)
        self.player = GesturePlayer(g1.JOINT_NAMES, -unbounded, unbounded)
        self.base = np.asarray(cfg.base, dtype=np.float64)
        arm = np.zeros(g1.NUM_JOINTS, dtype=bool)
        arm[g1.joint_indices(g1.ARM_JOINTS)] = True
        self._arms = arm
        self.styles: dict[str, GestureStyle] = {}
        for index, name in enumerate(GESTURE_LABELS):
            if index == 0:
                continue
            moved = np.zeros(g1.NUM_JOINTS, dtype=bool)
            moved[self.player.index] = self.player.joint_weights(index, 1.0) > 0.0
            self.styles[name] = GestureStyle(name, index, moved & arm, self._spacing(name))

    def _spacing(self, name: str) -> int:
        """Frames between keyframes: linear interpolation of A sin(wt) at step h errs by at most A (wh)^2 / 8."""
        curvature = max((amplitude * (2 * math.pi * freq) ** 2 for amplitude, freq in MOTIONS.get(name, {}).values()), default=0.0)
        if curvature == 0.0:
            return self.cfg.spacing_frames
        step_s = math.sqrt(8.0 * self.cfg.tolerance / curvature)
        return max(1, min(self.cfg.spacing_frames, math.floor(step_s * FPS)))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.styles)

    def style(self, name: str) -> GestureStyle:
        """The library entry of `name`, or ConfigError listing the valid names."""
        try:
            return self.styles[name]
        except KeyError:
            raise ConfigError(f"unknown gesture '{name}' (valid: {', '.join(self.styles)}, or '' for none)") from None

    def arm_angles(self, gestures: Sequence[Gesture], t: float) -> tuple[FloatArray, BoolArray]:
        """Joint angles [29] at run time `t` with the gestures layered in start order on the base pose, and the arm joints they hold.

        A gesture that has blended out still holds its joints, on the base pose.
        """
        q = self.base
        held = np.zeros(g1.NUM_JOINTS, dtype=bool)
        for gesture in sorted(gestures, key=lambda g: g.start):
            if gesture.start > t + 1e-9:
                continue
            style = self.style(gesture.name)
            q = self.player.apply(q, style.index, gesture.weight(t, self.cfg.blend_s), t - gesture.start)
            held |= style.arms
        return q, held

    def keyframes(self, gestures: Sequence[Gesture], first_frame_time: float, frames: int, hold_rest: bool = False) -> tuple[Keyframe, ...]:
        """Arm keyframes for a plan of `frames` frames whose frame k is at run time `first_frame_time + k / FPS`.

        On the last frame and every `spacing` frames back from it (the densest spacing of the
        gestures in play), none on frame 0 (the plan leaves the context smoothly); root free.
        Once every gesture has blended out, one more keyframe puts the arms on the base pose
        (the plan holds it from there) and the rest of the plan is the planner's.

        `hold_rest`: the arm joints no gesture moves are held on the base pose over the whole
        plan, with or without gestures ("raise your right arm" leaves the left one down, "turn
        right" both: see `SmartLocomotion.hold_free_arms`).
        """
        if not gestures and not hold_rest:
            return ()
        spacing = min((self.style(g.name).spacing_frames for g in gestures), default=self.cfg.spacing_frames)
        out = []
        for frame in reversed(range(frames - 1, 0, -spacing)):
            t = first_frame_time + frame / FPS
            q, held = self.arm_angles(gestures, t)
            if hold_rest:
                held = held | self._arms
            if held.any():
                qpos = np.array(g1.standing_qpos())
                qpos[g1.QPOS_JOINTS] = q
                out.append(Keyframe(frame, qpos, joints=held, root=False, root_height=False))
            if not hold_rest and not any(g.alive(t, self.cfg.blend_s) for g in gestures):
                break
        return tuple(out)


def merged(keyframe: Keyframe, arms: Keyframe) -> Keyframe:
    """`keyframe` also holding the joints `arms` holds, at their angles (the root constraints stay `keyframe`'s).

    A request takes one keyframe per frame, so arms on the root target's frame join it.
    """
    if keyframe.frame != arms.frame:
        raise ConfigError(f"cannot merge keyframes of frames {keyframe.frame} and {arms.frame}")
    qpos = np.array(keyframe.qpos, dtype=np.float64)
    joints = np.asarray(arms.joints, dtype=bool)
    qpos[g1.QPOS_JOINTS] = np.where(joints, arms.qpos[g1.QPOS_JOINTS], qpos[g1.QPOS_JOINTS])
    return Keyframe(
        keyframe.frame,
        qpos,
        joints=np.asarray(keyframe.joints, dtype=bool) | joints,
        root=keyframe.root,
        root_height=keyframe.root_height,
    )
