"""The planned reference: the command drives the planner, the tracker reads the plan buffer.

Each tick the supervised velocity command goes to smart locomotion, the scheduler asks
for plans (at 10 Hz, and at once on a meaningful command change) and the tracker gets a
`ReferenceWindow` with the plan sampled now and a little ahead. In the waypoints mode a
`WaypointFollower` gives both commands instead: the window's from the measured root (the
legs follow it), the planner's from the planned root, both towards the current target.
No MuJoCo, no torch.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controller.inputs.base import VelocityCommand
from controller.planner.request import Plan, PlanRequest
from controller.reference.buffer import ReferenceBuffer
from controller.reference.locomotion import LocomotionConfig, SmartLocomotion
from controller.reference.scheduler import ReplanScheduler, SchedulerConfig
from controller.reference.source import ReferenceSource
from controller.reference.waypoints import WaypointFollower
from controller.reference.window import ReferenceWindow
from controller.reports import percentiles_ms
from hw import g1
from hw.types import FloatArray, RobotState


@dataclass(frozen=True)
class PlannedReferenceConfig:
    locomotion: LocomotionConfig = field(default_factory=LocomotionConfig)
    scheduler: SchedulerConfig = field(default_factory=SchedulerConfig)
    lead_s: float = 0.5  # the tracker takes the planned root's mean velocity over this much of the plan ahead
    path_lead_s: float = 0.1  # ... or the root path's velocity this far ahead
    command_change: float = 0.1  # m/s or rad/s: a change this large asks for a plan at once


class PlannedReference(ReferenceSource):
    """Plans from the command, replanned at 10 Hz, read by time from the buffer."""

    def __init__(
        self,
        plan: Callable[[PlanRequest], Plan],  # the planner: controller.planner.runtime.Planner.plan
        cfg: PlannedReferenceConfig = PlannedReferenceConfig(),
        simulated_clock: bool = True,
        joint_limits: tuple[FloatArray, FloatArray] | None = None,
        seed: int = 0,
        follower: WaypointFollower | None = None,  # waypoints mode: the command comes from it
    ) -> None:
        self.cfg = cfg
        self.follower = follower
        self.buffer = ReferenceBuffer()
        self.locomotion = SmartLocomotion(cfg.locomotion, seed)
        self.scheduler = ReplanScheduler(plan, self.locomotion.request, self.buffer, cfg.scheduler, simulated_clock, joint_limits)
        self._last_command: VelocityCommand | None = None

    def start(self, state: RobotState) -> None:
        """Hold the robot's measured pose until the first plan arrives."""
        qpos = np.zeros(g1.QPOS_SIZE)
        qpos[g1.QPOS_ROOT_POS] = state.base_pos
        qpos[g1.QPOS_ROOT_QUAT] = state.base_quat
        qpos[g1.QPOS_JOINTS] = state.joint_pos
        self.buffer.reset(qpos, state.time)
        if self.follower is not None:
            self.follower.start(state)

    def window(self, state: RobotState, velocity: VelocityCommand, gesture: str = "") -> ReferenceWindow:
        t = state.time
        planned = velocity  # what the planner is asked for
        if self.follower is not None:  # the legs walk the robot to the target, the planner walks the plan there
            velocity = self.follower.command(state)
            planned = self.follower.plan_command(self.buffer.sample(t).qpos, self.cfg.locomotion.spring)
        changed = self._last_command is None or _differs(planned, self._last_command, self.cfg.command_change)
        changed = self.locomotion.set_gesture(gesture, t) or changed
        if changed:
            self._last_command = planned
        self.locomotion.command = planned
        self.scheduler.update(t, replan_now=changed)
        return ReferenceWindow(
            t,
            velocity,
            plan=self.buffer.sample(t),
            ahead=self.buffer.sample(t + self.cfg.lead_s),
            path_velocity=self.locomotion.path_velocity(t + self.cfg.path_lead_s),
        )

    def report(self) -> dict[str, Any]:
        c = self.scheduler.counters
        return {
            "plan_latency_ms": percentiles_ms(self.scheduler.plan_latencies_s),
            "replans": c.replans,
            "late_plans": c.late_plans,
            "planner_failures": c.planner_failures,
            "plan_clamped_values": c.clamped_values,
        } | (self.follower.report() if self.follower is not None else {})

    def close(self) -> None:
        self.scheduler.close()


def _differs(a: VelocityCommand, b: VelocityCommand, tol: float) -> bool:
    return math.hypot(a.vx - b.vx, a.vy - b.vy) > tol or abs(a.yaw_rate - b.yaw_rate) > tol
