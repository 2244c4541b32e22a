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

import dataclasses
import math
import time
from collections.abc import Sequence

import numpy as np

from controller.assets import ensure_assets
from controller.estimation.config import EstimatorConfig, load_estimator_config
from controller.estimation.contact import ContactDetector
from controller.estimation.filter import predict, update
from controller.estimation.kinematics import LegKinematics
from hw.errors import ConfigError
from hw.types import FloatArray, RobotState

# Rows of the filter's state (columns: world x, y, z).
POS, VEL, LEFT, RIGHT = 0, 1, 2, 3
# Measurements: left foot - base, right foot - base, base velocity from the left foot, from the right foot.
_H = np.array([[-1.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
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
        self._gravity = np.array([0.0, 0.0, -config.gravity])
        proc, meas = config.process, config.measurement
        # Process noise per second and measurement noise, for each contact pair (left, right).
        self._q_rate: dict[tuple[bool, bool], FloatArray] = {}
        self._r: dict[tuple[bool, bool], FloatArray] = {}
        for pair in ((False, False), (False, True), (True, False), (True, True)):
            feet = [(proc.stance_foot if down else proc.swing_foot) ** 2 for down in pair]
            self._q_rate[pair] = np.diag([proc.position**2, proc.accel**2, *feet])
            velocity = [meas.foot_velocity**2 if down else _SWING_VELOCITY_VARIANCE for down in pair]
            self._r[pair] = np.diag([meas.foot_position**2, meas.foot_position**2, *velocity])
        self._f = np.eye(4)
        self._b = np.zeros((4, 1))
        self._measured = np.zeros((4, 3))  # the measurement: each foot relative to the base, the base velocity each implies
        self.update_seconds: list[float] = []
        self.reset()

    @classmethod
    def for_g1(cls, joint_names: Sequence[str], config_path: str | None = None, assets_dir: str | None = None) -> StateEstimator:
        """The estimator of the G1: settings from `config_path` (default: the shipped one), legs from the G1 model."""
        config = load_estimator_config(config_path)
        return cls(config, LegKinematics.from_mjcf(ensure_assets(assets_dir).g1_mjcf), joint_names)

    def reset(self) -> None:
        """The next update starts a new estimate: at the origin (z from the stance legs), heading the IMU's."""
        self._x = np.zeros((4, 3))
        self._p = np.zeros((4, 4))
        self._time: float | None = None
        self._fault: str | None = None
        self._good = (np.zeros(3), np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))  # the last trusted position, velocity, attitude
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
        return math.sqrt(self._p[POS, POS])

    def update(self, state: RobotState) -> RobotState:
        """One step on `state` as hardware measures it; returns it with base_pos, base_lin_vel, base_quat estimated."""
        start = time.perf_counter()
        try:
            if self._fault is None:
                self._step(state)
            return self._output(state)
        finally:
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
            return  # the same reading again: nothing new to fuse

        w, x, y, z = state.base_quat.tolist()
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        if not norm > 1e-6:
            self._fault = "non-finite input: base_quat" if math.isnan(norm) else f"base_quat is no rotation (length {norm:.3g})"
            return
        w, x, y, z = w / norm, x / norm, y / norm, z / norm
        rot = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )
        gx, gy, gz = state.base_ang_vel.tolist()
        omega_t = np.array([[0.0, gz, -gy], [-gz, 0.0, gx], [gy, -gx, 0.0]])  # r @ omega_t = omega x r
        kin = self.kinematics
        kin.update(state.joint_pos[self._legs], state.joint_vel[self._legs])
        measured = self._measured
        feet, base_velocity = measured[:2], measured[2:]
        np.matmul(kin.foot_pos, rot.T, out=feet)  # each contact point relative to the base, world axes
        np.matmul(-(kin.foot_vel + kin.foot_pos @ omega_t), rot.T, out=base_velocity)  # what each foot implies, if it stands
        accel = rot @ state.imu_accel + self._gravity
        if not math.isfinite(float(measured.sum()) + float(accel.sum())):
            self._fault = f"non-finite input: {_first_nonfinite(state, self._legs)}"
            return
        self._time = state.time
        left, right = feet[:, 2].tolist()
        contacts = self._contact.decide(left, right)
        if first:
            self._start(feet, base_velocity, contacts)
            return
        f, b = self._f, self._b
        f[POS, VEL] = dt
        b[POS, 0], b[VEL, 0] = 0.5 * dt * dt, dt
        x_prior, p_prior = predict(self._x, self._p, f, self._q_rate[contacts] * dt, b * accel)
        r = self._r[contacts].copy()  # the higher foot's velocity counts for less, the higher it is
        lowest, scale = min(left, right), self.config.measurement.height_scale
        gaps = (left - lowest, right - lowest)
        r[2, 2] *= (1.0 + gaps[0] / scale) ** 2
        r[3, 3] *= (1.0 + gaps[1] / scale) ** 2
        self._x, self._p, _ = update(x_prior, p_prior, _H, r, measured)
        self._watch_slip(base_velocity, x_prior[VEL], float(p_prior[VEL, VEL]), gaps, dt)
        if self._fault is None:
            self._watch_estimate()

    def _start(self, feet: FloatArray, base_velocity: FloatArray, contacts: tuple[bool, bool]) -> None:
        """The first estimate: x = y = 0, the base as high above the ground as its stance feet are below it."""
        stance = [i for i in (0, 1) if contacts[i]] or [int(np.argmin(feet[:, 2]))]  # none decided: the lower foot
        self._x[POS] = (0.0, 0.0, -float(np.mean(feet[stance, 2])))
        self._x[VEL] = np.mean(base_velocity[stance], axis=0)
        self._x[LEFT:] = self._x[POS] + feet
        meas = self.config.measurement
        self._p = np.diag([0.0, meas.foot_velocity**2, meas.foot_position**2, meas.foot_position**2])

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
        if not (np.isfinite(self._x).all() and np.isfinite(self._p).all()):
            self._fault = "the estimate became non-finite"
        elif self.position_std > self.config.fault.max_position_std:
            limit = self.config.fault.max_position_std
            self._fault = f"the estimate diverged: position standard deviation {self.position_std:.2f} m (limit {limit} m)"

    def _output(self, state: RobotState) -> RobotState:
        """The estimate while it is trusted; after a fault the last trusted one (the attitude stays the IMU's while it is finite)."""
        if self._fault is None and self._time is not None:
            self._good = (self._x[POS].copy(), self._x[VEL].copy(), state.base_quat)
        pos, vel, attitude = self._good
        if self._fault is not None and np.isfinite(state.base_quat).all():
            attitude = state.base_quat
        return dataclasses.replace(state, base_pos=pos.copy(), base_lin_vel=vel.copy(), base_quat=attitude, has_base_position=True)


def _first_nonfinite(state: RobotState, legs: FloatArray) -> str:
    """The first field of `state` the estimator reads that holds a NaN or an infinity."""
    fields = {"joint_pos (legs)": state.joint_pos[legs], "joint_vel (legs)": state.joint_vel[legs], "base_quat": state.base_quat}
    fields |= {"base_ang_vel": state.base_ang_vel, "imu_accel": state.imu_accel}
    return next((name for name, values in fields.items() if not np.isfinite(values).all()), "the base attitude")
