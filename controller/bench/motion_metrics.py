"""In-betweening metrics over forward-kinematics outputs, in pure numpy (no MuJoCo).

Inputs are what `sim.kinematics.G1Kinematics.forward` returns, optionally stacked over
windows of the same length: body positions [..., T, B, 3] (m, world frame), body
quaternions w,x,y,z [..., T, B, 4], foot contact points [..., T, 2, 3], at `fps` frames
per second; body 0 is the pelvis (the root). Every function pools over all leading
dimensions (windows), so a batch gives one figure.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import ArrayLike, NDArray

from controller.planner.plausibility import CONTACT_HEIGHT_M
from controller.planner.request import FPS
from hw import quat

FloatArray = NDArray[np.float64]

REACH_POSITION_M = 0.05
REACH_HEADING_RAD = np.deg2rad(15.0)
ROOT_BODY_INDEX = 0  # the pelvis in the body axis B (hw.g1.ROOT_BODY names it)


def l2p(pred_pos: ArrayLike, true_pos: ArrayLike) -> float:
    """Mean Euclidean distance (m) between predicted and true body positions, over frames and bodies."""
    diff = np.asarray(pred_pos, dtype=np.float64) - np.asarray(true_pos, dtype=np.float64)
    return float(np.mean(np.linalg.norm(diff, axis=-1)))


def l2q(pred_quat: ArrayLike, true_quat: ArrayLike) -> float:
    """Mean geodesic angle (rad) between predicted and true body rotations, over frames and bodies."""
    return float(np.mean(quat.angle(pred_quat, true_quat)))


def npss(pred: ArrayLike, true: ArrayLike) -> float:
    """Normalized power spectrum similarity of features [..., T, F] (here: joint angles over the transition).

    As in Harvey et al. 2020 ("Robust Motion In-betweening", after Gopalakrishnan et al.
    2019): per sequence and feature, the power spectrum over time (|FFT|^2, one-sided),
    normalized to sum 1; the earth mover's distance between true and predicted spectra is
    the L1 norm of the difference of their cumulative sums; the result is the average of
    those distances weighted by each true feature's total power. 0 for identical inputs.
    (Harvey's reference code squares only the real part of the FFT; this uses the power.)
    A feature with no power at all is a constant zero: its spectrum is all at frequency 0.
    """
    p = np.asarray(pred, dtype=np.float64)
    t = np.asarray(true, dtype=np.float64)
    if p.shape != t.shape or p.ndim < 2:
        raise ValueError(f"npss needs two [..., T, F] arrays of one shape, got {p.shape} and {t.shape}")
    p_power = np.abs(np.fft.rfft(p, axis=-2)) ** 2
    t_power = np.abs(np.fft.rfft(t, axis=-2)) ** 2
    t_total = t_power.sum(axis=-2)
    emd = np.abs(np.cumsum(_unit_spectrum(p_power), axis=-2) - np.cumsum(_unit_spectrum(t_power), axis=-2)).sum(axis=-2)
    if t_total.sum() <= 0:
        return float(emd.mean())
    return float(np.average(emd, weights=t_total))


def contacts(feet: ArrayLike, height: float = CONTACT_HEIGHT_M) -> NDArray[np.bool_]:
    """Contact labels [..., T, 2] from foot points [..., T, 2, 3]: lower than `height` in this frame and the next."""
    low = np.asarray(feet, dtype=np.float64)[..., 2] < height
    contact = low.copy()
    contact[..., :-1, :] &= low[..., 1:, :]
    return contact


def foot_skate(feet: ArrayLike, fps: float = FPS, height: float = CONTACT_HEIGHT_M) -> float:
    """Mean horizontal foot speed (m/s) from frame t to t+1 over the (frame, foot) pairs in contact at t.

    Contact at t means the foot point is lower than `height` at t and at t+1, so every
    counted step has both ends on the ground. 0 when no foot is ever in contact.
    """
    points = np.asarray(feet, dtype=np.float64)
    speed = np.linalg.norm(np.diff(points[..., :2], axis=-3), axis=-1) * fps  # [..., T-1, 2]
    mask = contacts(points, height)[..., :-1, :]
    return float(speed[mask].mean()) if mask.any() else 0.0


def acceleration(pos: ArrayLike, fps: float = FPS) -> FloatArray:
    """Acceleration magnitudes (m/s^2) [..., T-2, B] by the second finite difference of positions [..., T, B, 3]."""
    p = np.asarray(pos, dtype=np.float64)
    return np.linalg.norm(p[..., 2:, :, :] - 2 * p[..., 1:-1, :, :] + p[..., :-2, :, :], axis=-1) * fps**2


def joint_jitter(pos: ArrayLike, fps: float = FPS) -> float:
    """Mean acceleration magnitude (m/s^2) over frames and all bodies."""
    return float(acceleration(pos, fps).mean())


def root_jitter(pos: ArrayLike, fps: float = FPS) -> float:
    """Mean acceleration magnitude (m/s^2) of the root body (the pelvis)."""
    p = np.asarray(pos, dtype=np.float64)
    return float(acceleration(p[..., ROOT_BODY_INDEX : ROOT_BODY_INDEX + 1, :], fps).mean())


def keyframe_error(pred_pos: ArrayLike, true_pos: ArrayLike) -> FloatArray:
    """Largest body position error (m) at one frame: bodies [..., B, 3] -> [...]."""
    diff = np.asarray(pred_pos, dtype=np.float64) - np.asarray(true_pos, dtype=np.float64)
    return np.asarray(np.linalg.norm(diff, axis=-1).max(axis=-1))


def root_error(pred_root: ArrayLike, true_root: ArrayLike) -> FloatArray:
    """Horizontal root position error (m): root positions [..., 3] -> [...]."""
    diff = np.asarray(pred_root, dtype=np.float64)[..., :2] - np.asarray(true_root, dtype=np.float64)[..., :2]
    return np.asarray(np.linalg.norm(diff, axis=-1))


def heading_error(pred_quat: ArrayLike, true_quat: ArrayLike) -> FloatArray:
    """Absolute heading difference (rad, in [0, pi]) between root quaternions [..., 4]."""
    return np.asarray(np.abs(quat.wrap_angle(quat.heading(pred_quat) - quat.heading(true_quat))))


def reached(
    pred_root: ArrayLike,
    pred_quat: ArrayLike,
    true_root: ArrayLike,
    true_quat: ArrayLike,
    position_m: float = REACH_POSITION_M,
    heading_rad: float = REACH_HEADING_RAD,
) -> NDArray[np.bool_]:
    """Whether the root is within `position_m` horizontally and `heading_rad` in heading of the target: [...]."""
    return np.asarray((root_error(pred_root, true_root) <= position_m) & (heading_error(pred_quat, true_quat) <= heading_rad))


def diversity(samples: ArrayLike) -> float:
    """Mean over pairs of samples of their mean body-position distance (m): samples [S, ..., B, 3]; 0 for S < 2."""
    s = np.asarray(samples, dtype=np.float64)
    pairs = list(itertools.combinations(range(len(s)), 2))
    if not pairs:
        return 0.0
    return float(np.mean([np.linalg.norm(s[i] - s[j], axis=-1).mean() for i, j in pairs]))


def _unit_spectrum(power: FloatArray) -> FloatArray:
    total = power.sum(axis=-2, keepdims=True)
    dc_only = np.zeros_like(power)
    dc_only[..., 0, :] = 1.0
    return np.where(total > 0, power / np.where(total > 0, total, 1.0), dc_only)
