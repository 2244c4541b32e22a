"""One update of the estimator, compiled: what `StateEstimator.update` runs on each reading.

Everything a tick computes is here, in one call: the attitude's rotation, the legs' kinematics,
each foot's position and the base velocity it implies, the contacts, the prediction, the four
corrections and the fault watches. A G1's update is a few hundred floating-point operations;
interpreted, its cost was the interpreter's (about 0.1 ms, half a tick's budget in the loop),
so it is compiled with numba (`cache=True`: compiled once per machine, loaded after). The
estimator's settings and its memory between updates are flat float arrays indexed by the enums
below, which is what a compiled call takes cheaply.
"""

from __future__ import annotations

import math
from enum import IntEnum

import numpy as np
from numba import njit
from numpy.typing import NDArray

from controller.estimation.config import EstimatorConfig
from controller.estimation.contact import decide_contacts
from controller.estimation.filter import NO_ROW, correct, predict
from controller.estimation.kinematics import LegConstants, leg_kinematics
from hw.types import FloatArray

# Rows of the filter's state (columns: world x, y, z).
POS, VEL, LEFT, RIGHT = 0, 1, 2, 3
_SWING_VELOCITY_VARIANCE = 1e6  # (m/s)^2: a foot in the air says nothing about the base's velocity


class Setting(IntEnum):
    """Where each setting sits in the array `settings` makes (variances, not standard deviations)."""

    GRAVITY = 0
    POSITION_RATE = 1  # process noise per second: the base position's own
    ACCEL_RATE = 2  # ... the base velocity's, from the IMU's acceleration
    STANCE_RATE = 3  # ... a foot on the ground's
    SWING_RATE = 4  # ... a foot in the air's
    FOOT_POSITION = 5  # measurement noise: a foot's position relative to the base
    FOOT_VELOCITY = 6  # ... the base velocity a stance foot implies
    HEIGHT_SCALE = 7
    CONTACT_MARGIN = 8
    CONTACT_HYSTERESIS = 9
    FLAT_HEIGHT = 10
    SLIP_TIME_CONSTANT = 11
    SLIP_SPEED = 12
    SLIP_CHI2 = 13
    MAX_POSITION_STD = 14
    SETTLE_TIME = 15


class Memory(IntEnum):
    """What the estimator carries from one update to the next besides the filter's state and covariance."""

    LEFT_CONTACT = 0  # 1.0 on the ground, 0.0 in the air
    RIGHT_CONTACT = 1
    SLIP_APART = 2  # m/s, low-pass filtered
    SLIP_CHI2 = 3  # low-pass filtered
    QUAT_NORM = 4  # the last attitude's length (a fault line reports it)
    LEFT_LANDING = 5  # s: how long the foot is still landing (it joined contact less than the settle time ago); 0: settled
    RIGHT_LANDING = 6


class Outcome(IntEnum):
    """What an update ended in; in this order: the ones before NONFINITE_INPUT fused the reading."""

    OK = 0
    SLIP_APART = 1
    SLIP_CHI2 = 2
    NONFINITE_ESTIMATE = 3
    DIVERGED = 4
    NONFINITE_INPUT = 5
    QUAT_NAN = 6
    QUAT_SHORT = 7


def settings(config: EstimatorConfig) -> FloatArray:
    """`config` as the array `estimator_step` reads (indexed by `Setting`)."""
    proc, meas, contact, fault = config.process, config.measurement, config.contact, config.fault
    values = {
        Setting.GRAVITY: config.gravity,
        Setting.POSITION_RATE: proc.position**2,
        Setting.ACCEL_RATE: proc.accel**2,
        Setting.STANCE_RATE: proc.stance_foot**2,
        Setting.SWING_RATE: proc.swing_foot**2,
        Setting.FOOT_POSITION: meas.foot_position**2,
        Setting.FOOT_VELOCITY: meas.foot_velocity**2,
        Setting.HEIGHT_SCALE: meas.height_scale,
        Setting.CONTACT_MARGIN: contact.height_margin,
        Setting.CONTACT_HYSTERESIS: contact.hysteresis,
        Setting.FLAT_HEIGHT: fault.flat_height,
        Setting.SLIP_TIME_CONSTANT: fault.slip_time_constant,
        Setting.SLIP_SPEED: fault.slip_speed,
        Setting.SLIP_CHI2: fault.slip_chi2,
        Setting.MAX_POSITION_STD: fault.max_position_std,
        Setting.SETTLE_TIME: contact.settle_time,
    }
    array = np.zeros(len(Setting))
    for setting, value in values.items():
        array[setting] = value
    return array


def fresh_memory() -> FloatArray:
    """The memory of an estimator that has not updated yet: both feet down and settled, no slip."""
    memory = np.zeros(len(Memory))
    memory[Memory.LEFT_CONTACT] = memory[Memory.RIGHT_CONTACT] = 1.0
    return memory


def load_compiled() -> None:
    """Run `estimator_step` once, on scratch arrays of the types a robot's readings have: numba loads its machine code
    from the cache now (0.2-1 s), or compiles it on a machine's first run (seconds). Called before a robot starts
    (the run driver, the estimator's constructor), never in a control tick, where the wait would starve the robot."""
    legs, model = np.arange(12, dtype=np.intp), LegConstants(*(np.zeros(shape) for shape in _MODEL_SHAPES))
    quat, accel, joints = np.array([1.0, 0.0, 0.0, 0.0]), np.array([0.0, 0.0, 9.81]), np.zeros(12)
    scratch = (np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3, 6)), np.zeros((2, 3, 6)))
    x, p, memory, values = np.zeros((4, 3)), np.zeros((4, 4)), fresh_memory(), np.ones(len(Setting))
    for dt, first in ((0.0, True), (0.02, False)):
        estimator_step(quat, np.zeros(3), accel, joints, joints, legs, dt, first, model, values, x, p, memory, *scratch)


_MODEL_SHAPES = ((2, 6, 3, 3), (2, 6, 3, 3), (2, 6, 3, 3), (2, 6, 3), (2, 6, 3), (3,))  # LegConstants' fields


@njit(cache=True)
def estimator_step(
    quat: FloatArray,
    omega: FloatArray,
    imu_accel: FloatArray,
    joint_pos: FloatArray,
    joint_vel: FloatArray,
    legs: NDArray[np.intp],
    dt: float,
    first: bool,
    model: LegConstants,
    settings: FloatArray,
    x: FloatArray,
    p: FloatArray,
    memory: FloatArray,
    foot_pos: FloatArray,
    foot_vel: FloatArray,
    jac_pos: FloatArray,
    jac_rot: FloatArray,
) -> int:
    """Fuse one reading (attitude `quat`, gyro `omega`, accelerometer `imu_accel`, the joints, `dt` after the last) into the
    state `x` (4, 3) and covariance `p` (4, 4), in place; `first`: start the estimate instead. Returns an `Outcome`.

    Each foot's contact point relative to the base, in world axes, is R r; the base velocity a standing foot implies is
    -R (J dq + w x r). The kinematics' outputs (`foot_pos` .. `jac_rot`) are left as scratch.
    """
    w, qx, qy, qz = quat[0], quat[1], quat[2], quat[3]
    norm = math.sqrt(w * w + qx * qx + qy * qy + qz * qz)
    memory[Memory.QUAT_NORM] = norm
    if not norm > 1e-6:
        return Outcome.QUAT_NAN.value if math.isnan(norm) else Outcome.QUAT_SHORT.value
    w, qx, qy, qz = w / norm, qx / norm, qy / norm, qz / norm
    rot = np.empty((3, 3))
    rot[0, 0], rot[0, 1], rot[0, 2] = 1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - w * qz), 2 * (qx * qz + w * qy)
    rot[1, 0], rot[1, 1], rot[1, 2] = 2 * (qx * qy + w * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - w * qx)
    rot[2, 0], rot[2, 1], rot[2, 2] = 2 * (qx * qz - w * qy), 2 * (qy * qz + w * qx), 1 - 2 * (qx * qx + qy * qy)
    leg_kinematics(joint_pos, joint_vel, legs, model, foot_pos, foot_vel, jac_pos, jac_rot)
    feet = np.empty((2, 3))  # each contact point relative to the base, world axes
    implied = np.empty((2, 3))  # the base velocity each foot implies, if it stands
    moving = np.empty(3)
    for leg in range(2):
        r = foot_pos[leg]
        moving[0] = -(foot_vel[leg, 0] + omega[1] * r[2] - omega[2] * r[1])
        moving[1] = -(foot_vel[leg, 1] + omega[2] * r[0] - omega[0] * r[2])
        moving[2] = -(foot_vel[leg, 2] + omega[0] * r[1] - omega[1] * r[0])
        for a in range(3):
            feet[leg, a] = rot[a, 0] * r[0] + rot[a, 1] * r[1] + rot[a, 2] * r[2]
            implied[leg, a] = rot[a, 0] * moving[0] + rot[a, 1] * moving[1] + rot[a, 2] * moving[2]
    accel = np.empty(3)  # the world's acceleration: R a_imu - g
    for a in range(3):
        accel[a] = rot[a, 0] * imu_accel[0] + rot[a, 1] * imu_accel[1] + rot[a, 2] * imu_accel[2]
    accel[2] -= settings[Setting.GRAVITY]
    if not math.isfinite(feet.sum() + implied.sum() + accel.sum()):
        return Outcome.NONFINITE_INPUT.value
    left, right = feet[0, 2], feet[1, 2]
    left_down, right_down = decide_contacts(
        left, right, memory[Memory.LEFT_CONTACT] > 0.5, memory[Memory.RIGHT_CONTACT] > 0.5,
        settings[Setting.CONTACT_MARGIN], settings[Setting.CONTACT_HYSTERESIS],
    )  # fmt: skip
    left_stands = _stands(left_down, memory[Memory.LEFT_CONTACT] > 0.5, Memory.LEFT_LANDING, dt, settings, memory)
    right_stands = _stands(right_down, memory[Memory.RIGHT_CONTACT] > 0.5, Memory.RIGHT_LANDING, dt, settings, memory)
    memory[Memory.LEFT_CONTACT], memory[Memory.RIGHT_CONTACT] = (1.0 if left_down else 0.0), (1.0 if right_down else 0.0)
    if first:
        _start(feet, implied, left_down, right_down, settings, x, p)
        return Outcome.OK.value

    q = np.empty(4)
    q[POS], q[VEL] = settings[Setting.POSITION_RATE] * dt, settings[Setting.ACCEL_RATE] * dt
    q[LEFT] = settings[Setting.STANCE_RATE if left_stands else Setting.SWING_RATE] * dt
    q[RIGHT] = settings[Setting.STANCE_RATE if right_stands else Setting.SWING_RATE] * dt
    predict(x, p, dt, accel, q)
    velocity_prior = x[VEL].copy()
    velocity_variance = p[VEL, VEL]  # the prediction's, before the corrections: the slip watch's yardstick
    r_foot, r_velocity = settings[Setting.FOOT_POSITION], settings[Setting.FOOT_VELOCITY]
    lowest, scale = min(left, right), settings[Setting.HEIGHT_SCALE]
    left_gap, right_gap = left - lowest, right - lowest  # the slip watch's
    correct(x, p, LEFT, POS, feet[0], r_foot)
    correct(x, p, RIGHT, POS, feet[1], r_foot)
    # A standing foot's velocity counts for less the higher it sits above the lower standing foot (a foot rolling onto its
    # toe or heel moves at its sole point); a landing foot, lower as it may be, is no reference: it is still sliding.
    ground = min(left if left_stands else math.inf, right if right_stands else math.inf)
    r_left = r_velocity * (1.0 + (left - ground) / scale) ** 2 if left_stands else _SWING_VELOCITY_VARIANCE
    r_right = r_velocity * (1.0 + (right - ground) / scale) ** 2 if right_stands else _SWING_VELOCITY_VARIANCE
    correct(x, p, VEL, NO_ROW, implied[0], r_left)
    correct(x, p, VEL, NO_ROW, implied[1], r_right)
    outcome = _watch_slip(implied, velocity_prior, velocity_variance, left_gap, right_gap, dt, settings, memory)
    if outcome != Outcome.OK:
        return outcome
    if not math.isfinite(x.sum() + p.sum()):  # a NaN or an infinity anywhere
        return Outcome.NONFINITE_ESTIMATE.value
    if math.sqrt(p[POS, POS]) > settings[Setting.MAX_POSITION_STD]:
        return Outcome.DIVERGED.value
    return Outcome.OK.value


@njit(cache=True)
def _stands(down: bool, was_down: bool, landing: int, dt: float, settings: FloatArray, memory: FloatArray) -> bool:
    """Whether a foot in contact (`down`; `was_down` at the last update) stands: it joined contact at least the settle time
    ago. Until then it is landing, its impact still sliding it on; `memory[landing]` counts that time down."""
    if not down:
        memory[landing] = 0.0
        return False
    memory[landing] = max(memory[landing] - dt, 0.0) if was_down else settings[Setting.SETTLE_TIME]
    return memory[landing] == 0.0


@njit(cache=True)
def _start(
    feet: FloatArray, implied: FloatArray, left_down: bool, right_down: bool, settings: FloatArray, x: FloatArray, p: FloatArray
) -> None:
    """The first estimate: x = y = 0, the base as high above the ground as its stance feet are below it."""
    stance = (left_down, right_down)
    if not left_down and not right_down:  # none decided: the lower foot
        stance = (feet[0, 2] <= feet[1, 2], feet[0, 2] > feet[1, 2])
    count = (1.0 if stance[0] else 0.0) + (1.0 if stance[1] else 0.0)
    x[:] = 0.0
    for leg in range(2):
        if stance[leg]:
            x[POS, 2] -= feet[leg, 2] / count
            x[VEL] += implied[leg] / count
    x[LEFT] = x[POS] + feet[0]
    x[RIGHT] = x[POS] + feet[1]
    p[:] = 0.0
    p[VEL, VEL] = settings[Setting.FOOT_VELOCITY]
    p[LEFT, LEFT] = p[RIGHT, RIGHT] = settings[Setting.FOOT_POSITION]


@njit(cache=True)
def _watch_slip(
    implied: FloatArray,
    velocity_prior: FloatArray,
    velocity_variance: float,
    left_gap: float,
    right_gap: float,
    dt: float,
    settings: FloatArray,
    memory: FloatArray,
) -> int:
    """A slip when, low-pass filtered, flat feet move apart or the stance foot's velocity leaves the IMU's prediction.

    The second is the filter's own test: the lower foot's horizontal velocity innovation squared, over its variance (the
    prediction's plus the measurement's), a chi-square statistic of 2 degrees of freedom (about 2 while the model holds).
    Feet breaking away take the estimate with them (the filter trusts the legs over the IMU); it shows here as the legs
    disagreeing with the IMU's acceleration. Only a sudden slide shows: a slow one is followed by the filter, and normal
    walking's command changes reach 61 (configs/estimator.yaml). Only flat feet count for the first (within
    `flat_height` of the lower one): a foot rolling onto its toe or heel moves at its sole point.
    """
    alpha = dt / (settings[Setting.SLIP_TIME_CONSTANT] + dt)
    lx, ly, lz = implied[0, 0] - velocity_prior[0], implied[0, 1] - velocity_prior[1], implied[0, 2] - velocity_prior[2]
    rx, ry, rz = implied[1, 0] - velocity_prior[0], implied[1, 1] - velocity_prior[1], implied[1, 2] - velocity_prior[2]
    flat = settings[Setting.FLAT_HEIGHT]
    apart = math.sqrt((lx - rx) ** 2 + (ly - ry) ** 2 + (lz - rz) ** 2) if left_gap < flat and right_gap < flat else 0.0
    horizontal = lx * lx + ly * ly if left_gap == 0.0 else rx * rx + ry * ry
    chi2 = horizontal / (velocity_variance + settings[Setting.FOOT_VELOCITY])  # the lower foot's: no height term
    memory[Memory.SLIP_APART] += alpha * (apart - memory[Memory.SLIP_APART])
    memory[Memory.SLIP_CHI2] += alpha * (chi2 - memory[Memory.SLIP_CHI2])
    if memory[Memory.SLIP_APART] > settings[Setting.SLIP_SPEED]:
        return Outcome.SLIP_APART.value
    if memory[Memory.SLIP_CHI2] > settings[Setting.SLIP_CHI2]:
        return Outcome.SLIP_CHI2.value
    return Outcome.OK.value
