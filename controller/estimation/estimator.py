"""The base's position, velocity and orientation from what hardware measures: IMU, joint encoders.

A linear Kalman filter (the design of legged_control's, per axis): the state is the base position
p and velocity v and the two feet's contact points fl, fr, all in the world frame. The IMU drives
the prediction (world acceleration R a_imu + g, R the IMU's attitude); the leg kinematics correct
it, each foot's position relative to the base (f - p = R r) and, for a foot on the ground, the base
velocity it implies (v = -R (J dq + w x r)). A foot in the air gets a large process noise, so its
contact point is taken afresh when it lands, once its impact has settled (contact.settle_time).
x, y and z share one 4-state covariance (filter.py).

Orientation is the IMU's attitude as measured, yaw included: its heading is the world's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from controller.assets import ensure_assets
from controller.estimation.config import EstimatorConfig, load_estimator_config
from controller.estimation.kinematics import LegKinematics
from controller.estimation.step import POS, VEL, Memory, Outcome, estimator_step, fresh_memory, load_compiled, settings
from hw.errors import ConfigError
from hw.types import FloatArray, RobotState


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
        self._legs = np.array([list(joint_names).index(name) for name in kinematics.joint_names], dtype=np.intp)
        self._settings = settings(config)
        self.reset()
        load_compiled()  # now, not in a robot's first control tick
        self.update_seconds: list[float] = []  # wall time of each update: what the control tick waits for
        self.update_cpu_seconds: list[float] = []  # this thread's CPU time of each: the update's own cost, without preemption

    @classmethod
    def for_g1(cls, joint_names: Sequence[str], config_path: str | None = None, assets_dir: str | None = None) -> StateEstimator:
        """The estimator of the G1: settings from `config_path` (default: the shipped one), legs from the G1 model."""
        config = load_estimator_config(config_path)
        return cls(config, LegKinematics.from_mjcf(ensure_assets(assets_dir).g1_mjcf), joint_names)

    def reset(self) -> None:
        """The next update starts a new estimate: at the origin (z from the stance legs), heading the IMU's."""
        self._x = np.zeros((4, 3))  # rows: base position, base velocity, left and right contact points; columns: x, y, z
        self._p = np.zeros((4, 4))  # the covariance all three columns share
        self._memory = fresh_memory()
        self._time: float | None = None
        self._fault: str | None = None
        self._good = (np.zeros(3), np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))  # the last trusted position, velocity, attitude

    @property
    def fault(self) -> str | None:
        """Why the estimate can no longer be trusted (latched until `reset`); None while it can."""
        return self._fault

    @property
    def contacts(self) -> tuple[bool, bool]:
        return bool(self._memory[Memory.LEFT_CONTACT]), bool(self._memory[Memory.RIGHT_CONTACT])

    @property
    def position_std(self) -> float:
        """The base position's standard deviation (m, the largest axis: all three share it)."""
        return math.sqrt(self._p[POS, POS])

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
        k = self.kinematics
        outcome = estimator_step(
            state.base_quat, state.base_ang_vel, state.imu_accel, state.joint_pos, state.joint_vel, self._legs, dt, first,
            k.constants, self._settings, self._x, self._p, self._memory, k.foot_pos, k.foot_vel, k.jac_pos, k.jac_rot,
        )  # fmt: skip
        if outcome < Outcome.NONFINITE_INPUT:
            self._time = state.time
        if outcome != Outcome.OK:
            self._fault = self._fault_line(outcome, state)

    def _fault_line(self, outcome: int, state: RobotState) -> str:
        """The one line that says why `estimator_step` gave up (`outcome`, an `Outcome`)."""
        cfg, memory = self.config.fault, self._memory
        if outcome == Outcome.QUAT_NAN:
            return "non-finite input: base_quat"
        if outcome == Outcome.QUAT_SHORT:
            return f"base_quat is no rotation (length {memory[Memory.QUAT_NORM]:.3g})"
        if outcome == Outcome.NONFINITE_INPUT:
            return f"non-finite input: {_first_nonfinite(state, self._legs) or 'the base attitude'}"
        if outcome == Outcome.SLIP_APART:
            return f"feet slipping: the stance feet move apart at {memory[Memory.SLIP_APART]:.2f} m/s (limit {cfg.slip_speed} m/s)"
        if outcome == Outcome.SLIP_CHI2:
            return (
                f"feet slipping: the stance foot's velocity left the IMU's prediction (chi-square {memory[Memory.SLIP_CHI2]:.1f}, "
                f"limit {cfg.slip_chi2})"
            )
        if outcome == Outcome.NONFINITE_ESTIMATE:
            return "the estimate became non-finite"
        return f"the estimate diverged: position standard deviation {self.position_std:.2f} m (limit {cfg.max_position_std} m)"

    def _output(self, state: RobotState) -> RobotState:
        """The estimate while it is trusted; after a fault the last trusted one (the attitude stays the IMU's while it is finite)."""
        if self._fault is None and self._time is not None:
            self._good = (self._x[POS].copy(), self._x[VEL].copy(), state.base_quat)
            pos, vel, attitude = self._good
        else:
            pos, vel, attitude = (value.copy() for value in self._good)
            if self._fault is not None and np.isfinite(state.base_quat).all():
                attitude = state.base_quat
        return RobotState(  # every field, written out: dataclasses.replace costs more than the update (a test checks the fields)
            time=state.time, joint_pos=state.joint_pos, joint_vel=state.joint_vel, base_quat=attitude, base_ang_vel=state.base_ang_vel,
            base_pos=pos, base_lin_vel=vel, has_base_position=True, imu_accel=state.imu_accel, joint_tau=state.joint_tau,
        )  # fmt: skip


def _first_nonfinite(state: RobotState, legs: NDArray[np.intp]) -> str | None:
    """The first field of `state` the estimator reads that holds a NaN or an infinity; None when all are finite."""
    fields: dict[str, FloatArray | None] = {"joint_pos (legs)": state.joint_pos[legs], "joint_vel (legs)": state.joint_vel[legs]}
    fields |= {"base_quat": state.base_quat, "base_ang_vel": state.base_ang_vel, "imu_accel": state.imu_accel}
    return next((name for name, values in fields.items() if values is not None and not np.isfinite(values).all()), None)
