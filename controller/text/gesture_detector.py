"""Arm gestures detected in executed G1 motion, by looking at the motion only (never at the plan).

`detect_gestures(qpos, fps)` names what the arms did in `qpos` frames [T, 36], from
`program.DETECTED_GESTURES`: wave_left, wave_right, wave_both, raise_left, raise_right, raise_both
(both arms together is the "_both" name, not the two one-arm names). Per arm, from a small numpy
forward kinematics of the waist and arm chains (no MuJoCo):

- height: palm over the shoulder pitch joint (m, world z); outward/forward: the palm's offset from the
  shoulder in the torso's heading frame (for debugging and tests);
- wave amplitude: envelope of the palm's path relative to the elbow in the upper arm's frame (so only
  the elbow and wrist count: arm swing, torso sway and a raised arm bouncing at the shoulder while
  walking do not), band-passed to 0.8-3 Hz.

An arm waves where that amplitude is above 5 cm with the palm no lower than 12 cm under the shoulder,
for 0.9 s or more; it is raised where the palm is over 15 cm above the shoulder and the arm is not
waving, for 0.8 s or more. `DetectorConfig` says how each threshold was chosen.

Measured on the recorded datasets (labelled segments where one gesture holds for >= 2 s, 0.5 s
blends trimmed at each end; thresholds calibrated on the train split, 895 segments, 75 min, where
every figure is also 1.000), test split of data/rec + data/rec2 (149 segments, 10.9 min):

    label           n  recall  precision  exact set   false positives (six names)
    wave_left       5  1.000   1.000      1.000       0
    wave_right     15  1.000   1.000      1.000       0
    wave_both       9  1.000   1.000      1.000       0
    raise_left      8  1.000   1.000      1.000       0
    raise_right    11  1.000   1.000      1.000       0
    raise_both     13  1.000   1.000      1.000       0
    none           47  -       -          1.000       0
    reach          15  -       -          1.000       0
    point          12  -       -          1.000       0
    arms_crossed    7  -       -          1.000       0
    hands_on_hips   7  -       -          1.000       0

Margins (train and test): wrong flags last 0.17 s at most (need 0.8-0.9 s); correct ones cover the
whole segment. Measured with a scratch script that cuts the segments as above and calls
`detect_gestures(clip.qpos[start:stop], clip.fps)` on clips from
`controller.motion_data.dataset.load_dataset("data/rec" | "data/rec2", split="test")`
(label "wave" is wave_right); the same cut is in the test module's dataset check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from controller.text.program import DETECTED_GESTURES
from hw import g1, quat
from hw.types import FloatArray

# --- forward kinematics of the waist and arms (pure numpy) -----------------------------------------
# Link offsets (m, in the parent link), fixed link rotations (w, x, y, z) and joint axes of the
# G1 29-DoF MJCF (holosoma's g1_29dof.xml), pelvis -> torso -> left arm -> palm site; the right
# arm is the left one mirrored in the sagittal plane. `tests/controller/text/test_gesture_detector.py`
# checks the palm and shoulder positions against MuJoCo's kinematics of the compiled model.
_X, _Y, _Z = np.eye(3)
_WAIST: tuple[tuple[tuple[float, float, float], FloatArray], ...] = (  # (offset, axis) in WAIST_JOINTS order
    ((0.0, 0.0, 0.0), _Z),  # waist_yaw_link on the pelvis
    ((-0.0039635, 0.0, 0.044), _X),  # waist_roll_link
    ((0.0, 0.0, 0.0), _Y),  # torso_link: waist pitch
)
_LEFT_ARM_CHAIN: tuple[tuple[tuple[float, float, float], tuple[float, float, float, float], FloatArray], ...] = (
    ((0.0039563, 0.10022, 0.24778), (0.990264, 0.139201, 1.38722e-05, -9.86868e-05), _Y),  # shoulder pitch
    ((0.0, 0.038, -0.013831), (0.990268, -0.139172, 0.0, 0.0), _X),  # shoulder roll
    ((0.0, 0.00624, -0.1032), (1.0, 0.0, 0.0, 0.0), _Z),  # shoulder yaw
    ((0.015783, 0.0, -0.080518), (1.0, 0.0, 0.0, 0.0), _Y),  # elbow
    ((0.1, 0.00188791, -0.01), (1.0, 0.0, 0.0, 0.0), _X),  # wrist roll
    ((0.038, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), _Y),  # wrist pitch
    ((0.046, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), _Z),  # wrist yaw
)
_PALM = np.array([0.08, 0.0, 0.0])  # the palm site in the wrist yaw link
SIDES = ("left", "right")
_ARM_COLUMNS = {"left": g1.joint_indices(g1.LEFT_ARM_JOINTS, qpos=True), "right": g1.joint_indices(g1.RIGHT_ARM_JOINTS, qpos=True)}
_WAIST_COLUMNS = g1.joint_indices(g1.WAIST_JOINTS, qpos=True)


def _mirror(offset: tuple[float, float, float], rot: tuple[float, float, float, float]) -> tuple[FloatArray, FloatArray]:
    """A left-side link's offset and fixed rotation reflected in the x-z plane (the right side's)."""
    (x, y, z), (w, qx, qy, qz) = offset, rot
    return np.array([x, -y, z]), np.array([w, -qx, qy, -qz])


def _rotations(axis: FloatArray, angle: FloatArray) -> FloatArray:
    """Rotation matrices [T, 3, 3] about a fixed unit `axis` by angles [T] (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


@dataclass(frozen=True)
class ArmPoints:
    """One arm over time: shoulder (pitch joint) and palm positions [T, 3] in the world frame, and the
    palm relative to the elbow joint in the upper arm's frame (the shoulder yaw link) [T, 3]."""

    shoulder: FloatArray
    palm: FloatArray
    forearm: FloatArray


def arm_points(qpos: FloatArray) -> dict[str, ArmPoints]:
    """Per side ("left", "right"), the arm's key points for G1 `qpos` frames [T, 36]."""
    qpos = np.asarray(qpos, dtype=np.float64)
    frames = len(qpos)
    position = qpos[:, g1.QPOS_ROOT_POS]
    rotation = quat.to_matrix(qpos[:, g1.QPOS_ROOT_QUAT])
    for (offset, axis), column in zip(_WAIST, _WAIST_COLUMNS, strict=True):
        position = position + rotation @ np.asarray(offset)
        rotation = rotation @ _rotations(axis, qpos[:, column])
    torso_pos, torso_rot = position, rotation
    out = {}
    for side in SIDES:
        position, rotation = torso_pos, torso_rot
        shoulder = elbow = np.zeros((frames, 3))
        upper_rot = np.zeros((frames, 3, 3))
        for i, ((offset, rot, axis), column) in enumerate(zip(_LEFT_ARM_CHAIN, _ARM_COLUMNS[side], strict=True)):
            off, q = (np.asarray(offset), np.asarray(rot)) if side == "left" else _mirror(offset, rot)
            position = position + rotation @ off
            rotation = rotation @ quat.to_matrix(q) @ _rotations(axis, qpos[:, column])
            if i == 0:
                shoulder = position
            elif i == 2:
                upper_rot = rotation
            elif i == 3:
                elbow = position
        palm = position + (rotation @ _PALM)
        forearm = np.einsum("tji,tj->ti", upper_rot, palm - elbow)
        out[side] = ArmPoints(shoulder, palm, forearm)
    return out


# --- features ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DetectorConfig:
    """Thresholds of the detector. Calibrated on the train split of data/rec (see the module docstring for
    the measured spread of each feature per labelled gesture); the test split is only reported."""

    # Hand "well above the shoulder": palm height over the shoulder pitch joint (m, world z). Raised arms
    # mostly hold 0.36-0.47 m, but under the low arm gains some raises sag to a median of 0.19-0.24 m;
    # arms that are neither raised nor waving stay below 0.08 m (reach, point). Midway, nearer the sag.
    # Waving arms reach 0.24 m: a waving arm is never also "raised".
    raise_height_m: float = 0.15
    # Shortest raise that counts (s). Every labelled raise holds for more than 1 s; a glance of the arm
    # upwards (or the 0.5 s blend in and out of another gesture) does not.
    raise_min_s: float = 0.8
    # Wave: the forearm's periodic motion, the palm's path relative to the elbow in the upper arm's frame
    # (elbow and wrist joints only, so arm swing, torso sway and a raised arm bouncing at the shoulder
    # while walking do not count), band-passed to the waving frequencies.
    wave_band_hz: tuple[float, float] = (0.8, 3.0)
    # Amplitude envelope of that motion (m). Waves run at 0.07-0.12 m; every other gesture and walking
    # stays below 0.03 m most of the time and peaks near 0.1 m for a moment (the step of the forearm
    # into the reach pose leaks into the band for about 0.2 s).
    wave_amplitude_m: float = 0.05
    envelope_smooth_s: float = 0.3  # moving mean of the envelope: a single jerk is not a wave
    # The waving arm is up or out: palm no lower than this under the shoulder (m). Waves hold the palm at
    # -0.09 m or higher; arms down, on the hips or crossed sit at -0.13 m or lower.
    wave_arm_up_m: float = -0.12
    wave_min_s: float = 0.9  # "about 1 s": over a period at 1.2 Hz; below the shortest labelled wave (1.03 s here)
    # Runs of a flag separated by a shorter gap than this (s) are one run (a wave's envelope dips at
    # direction changes, the tracker lets a raised arm sag for a moment).
    gap_s: float = 0.2

    def __post_init__(self) -> None:
        lo, hi = self.wave_band_hz
        if not 0.0 < lo < hi:
            raise ValueError(f"wave band {self.wave_band_hz} Hz must be 0 < low < high")
        if min(self.raise_min_s, self.wave_min_s, self.wave_amplitude_m) <= 0.0 or min(self.envelope_smooth_s, self.gap_s) < 0.0:
            raise ValueError("detector durations and the wave amplitude must be positive")


@dataclass(frozen=True)
class ArmFeatures:
    """One arm's features over time [T]: palm height over the shoulder (m, world z), the palm's outward
    and forward offsets from the shoulder in the torso's heading frame (m), and the amplitude envelope
    of the forearm's motion in the waving band (m)."""

    height: FloatArray
    outward: FloatArray
    forward: FloatArray
    wave_amplitude: FloatArray


def _check(qpos: FloatArray, fps: float) -> FloatArray:
    q = np.asarray(qpos, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != g1.QPOS_SIZE:
        raise ValueError(f"gesture detection needs G1 qpos frames [T, {g1.QPOS_SIZE}], got shape {list(q.shape)}")
    if not (np.isfinite(fps) and fps > 0.0):
        raise ValueError(f"frame rate must be a positive number of frames per second, got {fps}")
    bad = np.flatnonzero(~np.isfinite(q).all(axis=1))
    if bad.size:
        raise ValueError(f"qpos has non-finite values (NaN or inf) in {bad.size} frames, first at frame {bad[0]}")
    return q


def _band_envelope(x: FloatArray, fps: float, band: tuple[float, float]) -> FloatArray:
    """Amplitude envelope [T] of the band-passed vector signal x [T, 3]: norm of its analytic signal."""
    frames = len(x)
    pad = min(frames - 1, round(fps))  # mirror a second at each end against edge effects
    padded = np.pad(x - x.mean(axis=0), ((pad, pad), (0, 0)), mode="reflect")
    n = len(padded)
    spectrum = np.fft.fft(padded, axis=0)
    freq = np.abs(np.fft.fftfreq(n, 1.0 / fps))
    spectrum[(freq < band[0]) | (freq > band[1])] = 0.0
    # Analytic signal: keep the positive frequencies, doubled; the magnitude is the instantaneous amplitude.
    positive = np.fft.fftfreq(n) > 0
    spectrum = np.where(positive[:, None], 2.0 * spectrum, 0.0)
    analytic = np.fft.ifft(spectrum, axis=0)[pad : pad + frames]
    return np.sqrt((np.abs(analytic) ** 2).sum(axis=1))


def _moving_mean(x: FloatArray, width: int) -> FloatArray:
    if width <= 1:
        return x
    padded = np.pad(x, (width // 2, width - 1 - width // 2), mode="edge")
    return np.convolve(padded, np.ones(width) / width, mode="valid")


def arm_features(qpos: FloatArray, fps: float = 30.0, cfg: DetectorConfig | None = None) -> dict[str, ArmFeatures]:
    """Per side ("left", "right"), the features the detector reads, for G1 `qpos` frames [T, 36] at `fps`."""
    cfg = cfg or DetectorConfig()
    q = _check(qpos, fps)
    points = arm_points(q)
    # The torso's heading: the pelvis's plus the waist's yaw (its roll and pitch stay small).
    yaw = quat.heading(q[:, g1.QPOS_ROOT_QUAT]) + q[:, g1.joint_indices(["waist_yaw_joint"], qpos=True)[0]]
    cos, sin = np.cos(yaw), np.sin(yaw)
    out = {}
    for side, outward_sign in zip(SIDES, (1.0, -1.0), strict=True):
        arm = points[side]
        rel = arm.palm - arm.shoulder
        forward = cos * rel[:, 0] + sin * rel[:, 1]
        left = -sin * rel[:, 0] + cos * rel[:, 1]
        if len(q) > 1:
            envelope = _band_envelope(arm.forearm, fps, cfg.wave_band_hz)
            envelope = _moving_mean(envelope, round(cfg.envelope_smooth_s * fps))
        else:
            envelope = np.zeros(len(q))
        out[side] = ArmFeatures(rel[:, 2], outward_sign * left, forward, envelope)
    return out


# --- detection -----------------------------------------------------------------------------------


def _bridge(mask: NDArray[np.bool_], gap: int) -> NDArray[np.bool_]:
    """`mask` with false runs shorter than `gap` frames between two true runs filled in."""
    out = mask.copy()
    true = np.flatnonzero(mask)
    if true.size < 2:
        return out
    steps = np.diff(true)
    for k in np.flatnonzero((steps > 1) & (steps <= gap)):
        out[true[k] : true[k + 1]] = True
    return out


def _longest_run(mask: NDArray[np.bool_]) -> int:
    """Length (frames) of the longest run of true values."""
    if not mask.any():
        return 0
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return int((np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)).max())


def gesture_flags(qpos: FloatArray, fps: float = 30.0, cfg: DetectorConfig | None = None) -> dict[str, NDArray[np.bool_]]:
    """Per-frame flags [T] "wave_left", "wave_right", "raise_left", "raise_right": what each arm does in each frame
    (gaps shorter than `cfg.gap_s` bridged). A waving arm is not also raised."""
    cfg = cfg or DetectorConfig()
    features = arm_features(qpos, fps, cfg)
    gap = round(cfg.gap_s * fps)
    flags = {}
    for side, f in features.items():
        waving = _bridge((f.wave_amplitude > cfg.wave_amplitude_m) & (f.height > cfg.wave_arm_up_m), gap)
        flags[f"wave_{side}"] = waving
        flags[f"raise_{side}"] = _bridge((f.height > cfg.raise_height_m) & ~waving, gap)
    return flags


def detect_gestures(qpos: FloatArray, fps: float = 30.0, cfg: DetectorConfig | None = None) -> tuple[str, ...]:
    """Names of the gestures (from `DETECTED_GESTURES`, in that order) the G1 made in `qpos` frames [T, 36] at `fps`.

    Both arms doing the same thing together for the minimum time is "wave_both" / "raise_both", not the
    two one-arm names; an arm that did it alone at another time for the minimum time adds its own name.
    Raises ValueError for a wrong shape, a non-positive frame rate or non-finite values.
    """
    cfg = cfg or DetectorConfig()
    flags = gesture_flags(qpos, fps, cfg)
    found = set()
    for kind, min_s in (("wave", cfg.wave_min_s), ("raise", cfg.raise_min_s)):
        need = max(1, round(min_s * fps))
        left, right = flags[f"{kind}_left"], flags[f"{kind}_right"]
        both = left & right
        if _longest_run(both) >= need:
            found.add(f"{kind}_both")
        for side, mask in (("left", left), ("right", right)):
            if _longest_run(mask & ~both) >= need:
                found.add(f"{kind}_{side}")
    return tuple(name for name in DETECTED_GESTURES if name in found)
