"""What the motion data ever shows, and the counts of planned motion beyond it.

A planned frame is wild when its pelvis tilts further than any frame of the data, or its root
height moves further from the frame the plan continues, or from the frame before, than the data
ever moves in as many frames. A joint value is beyond the limits when it lies outside the G1's
range (hw/g1.py, from the MJCF). A keyframe is out of reach when its root is further from the
context than the data ever travels in the time the plan leaves for it. The in-the-loop report
(`controller/reference/planned.py`) and `g1ctl bench inbetween` count with these functions.

The constants are the largest values in the motion data, rounded up, computed by
`python -m controller.bench.motion_range --data ../shared/data/g1-moves` (the G1 Moves capture,
dance/ and bonus/: 32 clips, 31,914 frames at 30 fps). That capture is the widest motion in the
planner's data: the recorded locomotion (`g1ctl dataset record`) walks at most 0.8 m/s, upright.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hw import g1

FloatArray = NDArray[np.float64]

MAX_TILT_DEG = 59.8451  # pelvis z axis from vertical (J_Dance9_PeaceMaker)
MAX_HEIGHT_CHANGE_M = 0.2932  # root height, from a frame to any of the 64 after it (the longest plan; B_LongDance)
MAX_HEIGHT_STEP_M = 0.0469  # root height, from one frame to the next at 30 fps (J_Dance17_Shuffle)
# Mean planar root speed over 24 frames or more (the shortest plan; B_Fence2; slower over more). Over
# fewer frames the data moves faster (2.7 m/s from one frame to the next), so a keyframe before frame 23 is judged
# strictly. Heading needs no bound: the data turns 6.6 rad/s over 24 frames, and a target is never more than pi away.
MAX_REACH_SPEED_MPS = 1.2892

# A sole lower than this at two frames in a row is planted (the rule of sim.kinematics.foot_contacts, without MuJoCo).
CONTACT_HEIGHT_M = 0.05
JOINT_LOWER = np.array([joint.position_limits[0] for joint in g1.G1_JOINTS])
JOINT_UPPER = np.array([joint.position_limits[1] for joint in g1.G1_JOINTS])


def tilt_deg(qpos: ArrayLike) -> FloatArray:
    """The pelvis tilt (degrees, its z axis from vertical) of frames [..., 36]."""
    q = np.asarray(qpos, dtype=np.float64)[..., g1.QPOS_ROOT_QUAT]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    up = 1.0 - 2.0 * (q[..., 1] ** 2 + q[..., 2] ** 2)  # the body z axis's world z component
    return np.asarray(np.degrees(np.arccos(np.clip(up, -1.0, 1.0))))


def wild_frames(frames: ArrayLike, start: ArrayLike) -> NDArray[np.bool_]:
    """Which of `frames` [..., N, 36], continuing frame `start` [..., 36], go beyond the data: [..., N]."""
    f = np.asarray(frames, dtype=np.float64)
    before = np.asarray(start, dtype=np.float64)[..., None, :]
    height = f[..., 2]
    previous = np.concatenate((before[..., 2], height[..., :-1]), axis=-1)
    return np.asarray(
        (tilt_deg(f) > MAX_TILT_DEG)
        | (np.abs(height - before[..., 2]) > MAX_HEIGHT_CHANGE_M)
        | (np.abs(height - previous) > MAX_HEIGHT_STEP_M)
    )


def beyond_limits(joints: ArrayLike, tolerance: float = 0.0) -> NDArray[np.bool_]:
    """Which joint values [..., 29] lie outside the G1's limits by more than `tolerance` (rad)."""
    j = np.asarray(joints, dtype=np.float64)
    return np.asarray((j < JOINT_LOWER - tolerance) | (j > JOINT_UPPER + tolerance))


def out_of_reach(start: ArrayLike, target_xy: ArrayLike, frame: int, fps: float, longest: int) -> str | None:
    """Why a root at `target_xy` on plan frame `frame` cannot be reached from context frame `start` [36] by a plan of at
    most `longest` frames; None when it can."""
    distance = float(np.hypot(*(np.asarray(target_xy, dtype=np.float64)[:2] - np.asarray(start, dtype=np.float64)[:2])))
    seconds = (frame + 1) / fps
    speed = distance / seconds
    if speed <= MAX_REACH_SPEED_MPS:
        return None
    needed = int(np.ceil(distance / MAX_REACH_SPEED_MPS * fps)) - 1  # the earliest frame it could be reached at
    where = (
        f"place it at frame {needed} or later, in a plan longer than that"
        if needed < longest
        else f"no plan (at most {longest} frames) reaches it: ask for it over several plans"
    )
    return (
        f"the keyframe at frame {frame} is {distance:.2f} m from the context's root: {speed:.2f} m/s over {seconds:.2f} s, "
        f"faster than the motion data ever moves ({MAX_REACH_SPEED_MPS} m/s); {where}"
    )
