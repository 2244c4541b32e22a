"""The state estimator in a run: the robot as the controller sees it, and the estimate judged by the truth.

`EstimatedRobot` puts a `StateEstimator` between a backend's robot and the controller: every
read is one estimator update (the tracker's rate), so the session, the references and the
tracker see the estimated base position, velocity and heading, and nothing else changes
(the backend keeps its robot, and closes it). `attach_estimator` puts one where the plan of the run says.
`EstimateJudge` compares the estimate with the simulator's truth tick by tick where a
simulator stands behind the robot; the metrics of the run keep using the truth.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from controller.estimation.estimator import StateEstimator
from controller.reports import percentiles_ms
from controller.runtime.backend import Backend
from hw import quat
from hw.robot import RobotInterface
from hw.types import JointCommand, RobotState

if TYPE_CHECKING:
    from controller.reference.waypoints import WaypointError
    from controller.runtime.run_plan import RunPlan


def attach_estimator(backend: Backend, plan: RunPlan) -> EstimatedRobot | None:
    """The controller's view through a state estimator where the plan of the run puts one (`RunPlan.estimator`: every
    robot that measures no base position, and the simulator with `--estimator`, to judge the estimate by its truth)."""
    if not plan.estimator:
        return None
    robot = backend.robot
    return EstimatedRobot(robot, StateEstimator.for_g1(robot.joint_names, config_path=plan.estimator_config, assets_dir=plan.assets_dir))


class EstimatedRobot:
    """`robot` as the controller sees it: read through `estimator`; commands go straight through."""

    def __init__(self, robot: RobotInterface, estimator: StateEstimator) -> None:
        self.robot, self.estimator = robot, estimator
        self.measured: RobotState | None = None  # the last reading as the robot gave it (where the robot is a simulator: the truth)
        self.first_time: float | None = None
        self.last_time: float | None = None

    def read(self) -> RobotState:
        self.measured = self.robot.read()
        estimate = self.estimator.update(self.measured)
        if self.first_time is None:
            self.first_time = estimate.time
        self.last_time = estimate.time
        return estimate

    def reset(self) -> None:
        """The robot was put back at the start (the simulator after a fall): estimate afresh."""
        self.estimator.reset()

    def write(self, command: JointCommand) -> None:
        self.robot.write(command)

    def report(self) -> dict[str, Any]:
        """Always: how often and at what cost it ran, and whether it gave up (the cause)."""
        updates = len(self.estimator.update_seconds)
        span = (self.last_time or 0.0) - (self.first_time or 0.0)
        return {
            "rate_hz": round((updates - 1) / span, 2) if updates > 1 and span > 0 else None,
            "updates": updates,
            "update_ms": percentiles_ms(self.estimator.update_seconds),  # wall: what the tick waited, preemption included
            "update_cpu_ms": percentiles_ms(self.estimator.update_cpu_seconds),  # the update's own cost
            "fault": self.estimator.fault,
        }


class EstimateJudge:
    """The estimate against the simulator's truth, one sample per control tick.

    The estimate starts where the robot stood, facing the IMU's heading then; the truth is
    read in that frame (aligned at the first sample), so a drift is what the estimate lost
    along the way, not where the run began.
    """

    def __init__(self) -> None:
        self._origin: tuple[float, float, float, float, float, float] | None = None  # truth x, y, yaw; estimate x, y, yaw
        self._last_truth_xy = (0.0, 0.0)
        self.distance_m = 0.0
        self.first_time = self.last_time = 0.0
        self._velocity_sq: list[float] = []
        self._final: tuple[float, float] = (0.0, 0.0)  # planar drift (m), heading drift (rad) at the last sample
        self.contact_decisions = 0
        self.contact_disagreements = 0
        self._times: list[float] = []  # the controller's time of each sample ...
        self._truth_poses: list[tuple[float, float, float]] = []  # ... and the truth's pose then: x, y (m), heading (rad)

    def record(
        self, estimate: RobotState, truth: RobotState, estimated_contacts: tuple[bool, bool], true_contacts: tuple[bool, bool] | None
    ) -> None:
        # Plain floats: this runs every tick of a judged run, beside an estimator update of a few microseconds.
        tx, ty = truth.base_pos[:2].tolist()
        ex, ey = estimate.base_pos[:2].tolist()
        truth_yaw, estimate_yaw = quat.heading_of(truth.base_quat), quat.heading_of(estimate.base_quat)
        if self._origin is None:
            self._origin = (tx, ty, truth_yaw, ex, ey, estimate_yaw)
            self.first_time = estimate.time
        else:
            self.distance_m += math.hypot(tx - self._last_truth_xy[0], ty - self._last_truth_xy[1])
        self._last_truth_xy = (tx, ty)
        self.last_time = estimate.time
        self._times.append(estimate.time)
        self._truth_poses.append((tx, ty, truth_yaw))
        tx0, ty0, truth_yaw0, ex0, ey0, estimate_yaw0 = self._origin
        c, s = math.cos(estimate_yaw0 - truth_yaw0), math.sin(estimate_yaw0 - truth_yaw0)  # truth frame -> estimate frame
        dx, dy = tx - tx0, ty - ty0
        in_x, in_y = ex0 + c * dx - s * dy, ey0 + s * dx + c * dy
        tvx, tvy = truth.base_lin_vel[:2].tolist()
        evx, evy = estimate.base_lin_vel[:2].tolist()
        self._velocity_sq.append((evx - (c * tvx - s * tvy)) ** 2 + (evy - (s * tvx + c * tvy)) ** 2)
        heading = math.remainder((estimate_yaw - estimate_yaw0) - (truth_yaw - truth_yaw0), math.tau)
        self._final = (math.hypot(ex - in_x, ey - in_y), heading)
        if true_contacts is not None:
            self.contact_decisions += 2
            self.contact_disagreements += sum(e != t for e, t in zip(estimated_contacts, true_contacts, strict=True))

    def report(self) -> dict[str, Any]:
        """The issue's figures; None where nothing was recorded."""
        if self._origin is None:
            return {}
        minutes = (self.last_time - self.first_time) / 60.0
        drift, heading = self._final
        return {
            "judged_by": "truth",
            "distance_m": round(self.distance_m, 3),
            "position_drift_m": round(drift, 4),
            "drift_per_distance": round(drift / self.distance_m, 5) if self.distance_m > 0.1 else None,
            "heading_drift_deg_per_min": round(abs(math.degrees(heading)) / minutes, 3) if minutes > 0 else None,
            "velocity_rmse_mps": round(math.sqrt(float(np.mean(self._velocity_sq))), 4),
            "contact_decisions": self.contact_decisions,
            "contact_disagreements": self.contact_disagreements,
        }

    def restart(self) -> None:
        """The robot was put back at the start and the estimate begun afresh: the frames are aligned again, and the drift,
        the heading drift and the distance count from here (the velocity and contact errors keep the whole run)."""
        self._origin = None
        self.distance_m = 0.0

    def waypoint_errors(self, settled: Sequence[WaypointError]) -> list[dict[str, float]]:
        """Each waypoint's error when the controller settled on it, as the truth had the robot then."""
        errors = []
        for e in settled:
            i = min(bisect.bisect_left(self._times, e.time - 1e-9), len(self._times) - 1)
            x, y, heading = self._truth_poses[i]
            tx, ty, th = e.target
            miss = abs(math.degrees(float(quat.wrap_angle(th - heading))))
            errors.append({"position_m": round(math.hypot(tx - x, ty - y), 4), "heading_deg": round(miss, 3)})
        return errors
