"""The base's position, velocity and orientation from what hardware measures: IMU, joint encoders.

A linear Kalman filter (the design of legged_control's, per axis): the state is the base position
p and velocity v and the two feet's contact points fl, fr, all in the world frame. The IMU drives
the prediction (world acceleration R a_imu + g, R the IMU's attitude); the leg kinematics correct
it, each foot's position relative to the base (f - p = R r) and, for a foot on the ground, the base
velocity it implies (v = -R (J dq + w x r)). A foot in the air gets a large process noise, so its
contact point is taken afresh when it lands. x, y and z share one 4-state covariance (filter.py).

Orientation is the IMU's attitude as measured, yaw included: its heading is the world's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from controller.assets import ensure_assets
from controller.estimation.config import EstimatorConfig, load_estimator_config
from controller.estimation.contact import ContactDetector
from controller.estimation.filter import Rows, correct, predict
from controller.estimation.kinematics import LegKinematics
from hw.errors import ConfigError
from hw.types import FloatArray, RobotState

# Rows of the filter's state (columns: world x, y, z).
POS, VEL, LEFT, RIGHT = 0, 1, 2, 3
# Measurements (filter.correct): left foot - base, right foot - base, base velocity from the left foot, from the right foot.
_SWING_VELOCITY_VARIANCE = 1e6  # (m/s)^2: a foot in the air says nothing about the base's velocity


class StateEstimator:
    """Feed it each control tick's measured state; it returns the state with the base's pose and velocity estimated."""

    def __init__(self, config: EstimatorConfig, kinematics: LegKinematics, joint_names: Sequence[str]) -> None:
        missing = [name for name in kinematics.joint_names if name not in joint_names]
        if missing:
            raise ConfigError(
                f"the state estimator needs the leg joints {', '.join(missing)}; this robot's joints are {', '.join(joint_names)}"
            )
        self.config = config
        self.kinematics = kinematics
        self._legs = np.array([list(joint_names).index(name) for name in kinematics.joint_names])
        self._contact = ContactDetector(config.contact)
        proc, meas = config.process, config.measurement
        # Process noise per second (per state row) and the feet's velocity measurement variances, for each contact pair.
        self._q_rate: dict[tuple[bool, bool], tuple[float, ...]] = {}
        self._r_velocity: dict[tuple[bool, bool], tuple[float, ...]] = {}
        for pair in ((False, False), (False, True), (True, False), (True, True)):
            feet = [(proc.stance_foot if down else proc.swing_foot) ** 2 for down in pair]
            self._q_rate[pair] = (proc.position**2, proc.accel**2, *feet)
            self._r_velocity[pair] = tuple(meas.foot_velocity**2 if down else _SWING_VELOCITY_VARIANCE for down in pair)
        self.update_seconds: list[float] = []  # wall time of each update: what the control tick waits for
        self.update_cpu_seconds: list[float] = []  # this thread's CPU time of each: the update's own cost, without preemption
        self.reset()

    @classmethod
    def for_g1(cls, joint_names: Sequence[str], config_path: str | None = None, assets_dir: str | None = None) -> StateEstimator:
        """The estimator of the G1: settings from `config_path` (default: the shipped one), legs from the G1 model."""
        config = load_estimator_config(config_path)
        return cls(config, LegKinematics.from_mjcf(ensure_assets(assets_dir).g1_mjcf), joint_names)

    def reset(self) -> None:
        """The next update starts a new estimate: at the origin (z from the stance legs), heading the IMU's."""
        self._x: Rows = [[0.0] * 3 for _ in range(4)]
        self._p: Rows = [[0.0] * 4 for _ in range(4)]
        self._time: float | None = None
        self._fault: str | None = None
        self._good = ([0.0] * 3, [0.0] * 3, np.array([1.0, 0.0, 0.0, 0.0]))  # the last trusted position, velocity, attitude
        self._slip_apart = 0.0
        self._slip_chi2 = 0.0
        self._contact.reset()

    @property
    def fault(self) -> str | None:
        """Why the estimate can no longer be trusted (latched until `reset`); None while it can."""
        return self._fault

    @property
    def contacts(self) -> tuple[bool, bool]:
        return self._contact.contacts

    @property
    def position_std(self) -> float:
        """The base position's standard deviation (m, the largest axis: all three share it)."""
        return math.sqrt(self._p[POS][POS])

    def update(self, state: RobotState) -> RobotState:
        """One step on `state` as hardware measures it; returns it with base_pos, base_lin_vel, base_quat estimated."""
        start, start_cpu = time.perf_counter(), time.thread_time()
        try:
            if self._fault is None:
                self._step(state)
            return self._output(state)
        finally:
            self.update_cpu_seconds.append(time.thread_time() - start_cpu)
            self.update_seconds.append(time.perf_counter() - start)

    def _step(self, state: RobotState) -> None:
        first = self._time is None
        if state.imu_accel is None:
            if first:
                raise ConfigError(
                    "the state estimator needs the IMU's accelerometer (RobotState.imu_accel): this robot reports none; "
                    "use a backend that reads it"
                )
            self._fault = "the IMU's accelerometer reading (imu_accel) went missing"
            return
        dt = 0.0 if first else state.time - self._time  # type: ignore[operator]
        if dt > self.config.fault.max_gap:
            self._fault = f"no update for {dt:.3f} s (more than {self.config.fault.max_gap} s)"
            return
        if not first and not dt > 0.0:
            if not math.isfinite(dt):
                self._fault = "non-finite input: time"
            elif (bad := _first_nonfinite(state, self._legs)) is not None:
                self._fault = f"non-finite input: {bad}"  # a repeated time stamp carries no news, but a NaN is still a fault
            return  # the same reading again: nothing new to fuse

        w, x, y, z = state.base_quat.tolist()
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        if not norm > 1e-6:
            self._fault = "non-finite input: base_quat" if math.isnan(norm) else f"base_quat is no rotation (length {norm:.3g})"
            return
        w, x, y, z = w / norm, x / norm, y / norm, z / norm
        rot = (
            (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
            (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
            (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
        )
        omega = state.base_ang_vel.tolist()
        kin = self.kinematics
        kin.update(state.joint_pos[self._legs], state.joint_vel[self._legs])
        contact_points, foot_velocities = kin.foot_pos.tolist(), kin.foot_vel.tolist()
        feet = [_rotated(rot, point) for point in contact_points]  # each contact point relative to the base, world axes
        base_velocity = [  # what each foot implies, if it stands: -R (J dq + w x r)
            _rotated(rot, _negated_sum(velocity, _cross(omega, point)))
            for point, velocity in zip(contact_points, foot_velocities, strict=True)
        ]
        accel = _rotated(rot, state.imu_accel.tolist())
        accel[2] -= self.config.gravity
        if not math.isfinite(sum(feet[0]) + sum(feet[1]) + sum(base_velocity[0]) + sum(base_velocity[1]) + sum(accel)):
            self._fault = f"non-finite input: {_first_nonfinite(state, self._legs) or 'the base attitude'}"
            return
        self._time = state.time
        left, right = feet[0][2], feet[1][2]
        contacts = self._contact.decide(left, right)
        if first:
            self._start(feet, base_velocity, contacts)
            return
        x, p = self._x, self._p
        predict(x, p, dt, accel, [rate * dt for rate in self._q_rate[contacts]])
        velocity_prior = np.array(x[VEL])
        r_foot, (r_left, r_right) = self.config.measurement.foot_position**2, self._r_velocity[contacts]
        lowest, scale = min(left, right), self.config.measurement.height_scale
        gaps = (left - lowest, right - lowest)  # the higher foot's velocity counts for less, the higher it is
        velocity_variance = p[VEL][VEL]  # the prediction's, before the corrections: the slip watch's yardstick
        correct(x, p, LEFT, POS, feet[0], r_foot)
        correct(x, p, RIGHT, POS, feet[1], r_foot)
        correct(x, p, VEL, None, base_velocity[0], r_left * (1.0 + gaps[0] / scale) ** 2)
        correct(x, p, VEL, None, base_velocity[1], r_right * (1.0 + gaps[1] / scale) ** 2)
        self._watch_slip(np.array(base_velocity), velocity_prior, velocity_variance, gaps, dt)
        if self._fault is None:
            self._watch_estimate()

    def _start(self, feet: Rows, base_velocity: Rows, contacts: tuple[bool, bool]) -> None:
        """The first estimate: x = y = 0, the base as high above the ground as its stance feet are below it."""
        stance = [i for i in (0, 1) if contacts[i]] or [0 if feet[0][2] <= feet[1][2] else 1]  # none decided: the lower foot
        position = [0.0, 0.0, -sum(feet[i][2] for i in stance) / len(stance)]
        velocity = [sum(base_velocity[i][axis] for i in stance) / len(stance) for axis in range(3)]
        self._x = [position, velocity, *([position[axis] + foot[axis] for axis in range(3)] for foot in feet)]
        meas = self.config.measurement
        diagonal = (0.0, meas.foot_velocity**2, meas.foot_position**2, meas.foot_position**2)
        self._p = [[diagonal[i] if i == j else 0.0 for j in range(4)] for i in range(4)]

    def _watch_slip(
        self, base_velocity: FloatArray, velocity_prior: FloatArray, velocity_variance: float, gaps: tuple[float, float], dt: float
    ) -> None:
        """Latch a slip when, low-pass filtered, flat feet move apart or the stance foot's velocity leaves the IMU's prediction.

        The second is the filter's own test: the lower foot's horizontal velocity innovation squared, over its variance (the
        prediction's plus the measurement's), a chi-square statistic of 2 degrees of freedom (about 2 while the model holds).
        Feet breaking away take the estimate with them (the filter trusts the legs over the IMU); it shows here as the legs
        disagreeing with the IMU's acceleration. Only a sudden slide shows: a slow one is followed by the filter, and normal
        walking's command changes reach 61 (configs/estimator.yaml). Only flat feet count for the first (within
        `flat_height` of the lower one): a foot rolling onto its toe or heel moves at its sole point.
        """
        cfg = self.config.fault
        alpha = dt / (cfg.slip_time_constant + dt)
        (lx, ly, lz), (rx, ry, rz) = (base_velocity - velocity_prior).tolist()  # each foot's velocity against the IMU's prediction
        flat = cfg.flat_height
        apart = math.sqrt((lx - rx) ** 2 + (ly - ry) ** 2 + (lz - rz) ** 2) if gaps[0] < flat and gaps[1] < flat else 0.0
        horizontal = lx * lx + ly * ly if gaps[0] == 0.0 else rx * rx + ry * ry
        chi2 = horizontal / (velocity_variance + self.config.measurement.foot_velocity**2)  # the lower foot's: no height term
        self._slip_apart += alpha * (apart - self._slip_apart)
        self._slip_chi2 += alpha * (chi2 - self._slip_chi2)
        if self._slip_apart > cfg.slip_speed:
            self._fault = f"feet slipping: the stance feet move apart at {self._slip_apart:.2f} m/s (limit {cfg.slip_speed} m/s)"
        elif self._slip_chi2 > cfg.slip_chi2:
            self._fault = (
                f"feet slipping: the stance foot's velocity left the IMU's prediction (chi-square {self._slip_chi2:.1f}, "
                f"limit {cfg.slip_chi2})"
            )

    def _watch_estimate(self) -> None:
        if not math.isfinite(sum(map(sum, self._x)) + sum(map(sum, self._p))):  # a NaN or an infinity anywhere
            self._fault = "the estimate became non-finite"
        elif self.position_std > self.config.fault.max_position_std:
            limit = self.config.fault.max_position_std
            self._fault = f"the estimate diverged: position standard deviation {self.position_std:.2f} m (limit {limit} m)"

    def _output(self, state: RobotState) -> RobotState:
        """The estimate while it is trusted; after a fault the last trusted one (the attitude stays the IMU's while it is finite)."""
        if self._fault is None and self._time is not None:
            self._good = (self._x[POS][:], self._x[VEL][:], state.base_quat)
        pos, vel, attitude = self._good
        if self._fault is not None and np.isfinite(state.base_quat).all():
            attitude = state.base_quat
        return RobotState(  # every field, written out: dataclasses.replace costs 14 us of the budget's 200 (a test checks the fields)
            time=state.time, joint_pos=state.joint_pos, joint_vel=state.joint_vel, base_quat=attitude, base_ang_vel=state.base_ang_vel,
            base_pos=np.array(pos), base_lin_vel=np.array(vel), has_base_position=True, imu_accel=state.imu_accel,
            joint_tau=state.joint_tau,
        )  # fmt: skip


def _first_nonfinite(state: RobotState, legs: FloatArray) -> str | None:
    """The first field of `state` the estimator reads that holds a NaN or an infinity; None when all are finite."""
    fields = {"joint_pos (legs)": state.joint_pos[legs], "joint_vel (legs)": state.joint_vel[legs], "base_quat": state.base_quat}
    fields |= {"base_ang_vel": state.base_ang_vel, "imu_accel": state.imu_accel}
    return next((name for name, values in fields.items() if not np.isfinite(values).all()), None)


def _rotated(rot: tuple[tuple[float, float, float], ...], v: Sequence[float]) -> list[float]:
    """rot @ v on floats: a 3-vector costs less this way than one numpy call."""
    (a, b, c), (d, e, f), (g, h, i) = rot
    x, y, z = v
    return [a * x + b * y + c * z, d * x + e * y + f * z, g * x + h * y + i * z]


def _cross(a: Sequence[float], b: Sequence[float]) -> list[float]:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _negated_sum(a: Sequence[float], b: Sequence[float]) -> list[float]:
    return [-(a[0] + b[0]), -(a[1] + b[1]), -(a[2] + b[2])]
