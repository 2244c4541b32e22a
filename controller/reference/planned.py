"""The planned reference: the command drives the planner, the tracker reads the plan buffer.

Each tick the supervised velocity command goes to smart locomotion, the scheduler asks
for plans (at 10 Hz, and at once on a meaningful command change) and the tracker gets a
`ReferenceWindow` with the plan sampled now and a little ahead. In the waypoints mode a
`WaypointFollower` gives both commands instead: the window's from the measured root (the
legs follow it), the planner's from the planned root, both towards the current target.
When the robot has fallen behind the plan (a policy that cannot reach the planned speed,
a push) by more than `resync_distance_m` or `resync_heading_rad`, the whole buffer is moved
rigidly (about z) from where the plan is to where the robot is: the next plan starts from
the robot, and the reference never runs away from it. Moving the whole buffer, not only the
next context, keeps it continuous: a context across a jump would read as a burst of speed,
and the spring would run the plan ahead. The arms' angles do not change; the legs follow
the command. No MuJoCo, no torch.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controller.commands.velocity import VelocityCommand
from controller.planner.request import CONTEXT_FRAMES, Plan, PlanRequest
from controller.reference.buffer import ReferenceBuffer
from controller.reference.locomotion import LocomotionConfig, SmartLocomotion
from controller.reference.scheduler import ReplanScheduler, SchedulerConfig
from controller.reference.source import ReferenceSource
from controller.reference.waypoints import Follower
from controller.reference.window import ReferenceWindow
from controller.reports import percentiles_ms
from hw import g1, quat
from hw.types import FloatArray, RobotState


@dataclass(frozen=True)
class PlannedReferenceConfig:
    locomotion: LocomotionConfig = field(default_factory=LocomotionConfig)
    scheduler: SchedulerConfig = field(default_factory=SchedulerConfig)
    lead_s: float = 0.5  # the tracker takes the planned root's mean velocity over this much of the plan ahead
    path_lead_s: float = 0.1  # ... or the root path's velocity this far ahead
    command_change: float = 0.1  # m/s or rad/s: a change this large asks for a plan at once
    resync_distance_m: float = 0.1  # the plan's root this far from the measured root: the next plan starts from the robot
    resync_heading_rad: float = 0.1  # ... or its heading this far off


class PlannedReference(ReferenceSource):
    """Plans from the command, replanned at 10 Hz, read by time from the buffer."""

    needs_base_position = True  # plans are re-anchored on the measured root

    def __init__(
        self,
        plan: Callable[[PlanRequest], Plan],  # the planner: controller.planner.runtime.Planner.plan
        cfg: PlannedReferenceConfig = PlannedReferenceConfig(),
        simulated_clock: bool = True,
        joint_limits: tuple[FloatArray, FloatArray] | None = None,
        seed: int = 0,
        follower: Follower | None = None,  # waypoints mode (or a curve): the command comes from it
    ) -> None:
        self.cfg = cfg
        self.follower = follower
        self.buffer = ReferenceBuffer()
        self.locomotion = SmartLocomotion(cfg.locomotion, seed)
        self.scheduler = ReplanScheduler(plan, self._request, self.buffer, cfg.scheduler, simulated_clock, joint_limits)
        self._last_command: VelocityCommand | None = None
        self.resyncs = 0
        self._segment_start: tuple[int, bool] | None = None  # a new segment asked for: (crossfade frames, with its context)
        self._fresh_context = False  # the plan being asked for starts from a standing pose, not the buffer (naive joins)

    def start_segment(self, blend_frames: int | None, continue_motion: bool = True) -> None:
        """Ask for a plan at once that starts a new segment (the next clause of a text plan).

        `blend_frames`: it continues the executed motion (the buffer's context) and is blended
        into it over this many frames (Text2BFM-Compose's overlap). `continue_motion` False: the
        crossfade baseline, planned from a standing pose at the same root as if on its own, and
        crossfaded over the same frames. None: naive concatenation, planned from a standing pose
        and spliced with no blend.
        """
        self._segment_start = (0, False) if blend_frames is None else (blend_frames, continue_motion)

    def _request(self, context: FloatArray, splice_time: float) -> PlanRequest:
        if self._fresh_context:
            self._fresh_context = False
            context = standing_context(context[-1])
        return self.locomotion.request(context, splice_time)

    def start(self, state: RobotState) -> None:
        """Hold the robot's measured pose until the first plan arrives."""
        qpos = np.zeros(g1.QPOS_SIZE)
        qpos[g1.QPOS_ROOT_POS] = state.base_pos
        if not state.has_base_position:  # nothing estimates it (it reads zero): the plan stands at the standing height
            qpos[2] = g1.STANDING_PELVIS_HEIGHT
        qpos[g1.QPOS_ROOT_QUAT] = state.base_quat
        qpos[g1.QPOS_JOINTS] = state.joint_pos
        self.buffer.reset(qpos, state.time)
        if self.follower is not None:
            self.follower.start(state)

    def window(
        self, state: RobotState, velocity: VelocityCommand, gesture: str = "", hold: bool = False, gestures: tuple[str, ...] | None = None
    ) -> ReferenceWindow:
        """The window of this tick; `gestures` (one per arm, a text clause's tracks) in place of the one `gesture` when given."""
        t = state.time
        now = self.buffer.sample(t)
        # Standing in place the plan stays where the robot stood (measured on `wave`: moving it onto a robot that
        # sways with raised arms made both trackers fall, 1-3 times in 12 s; left in place, none did).
        moving = (self.follower is not None and not hold) or not velocity.is_zero(0.05)
        drift = self._drift(now.qpos, state) if state.has_base_position and moving else None
        if drift is not None:
            self.buffer.move(lambda frames: shift_frames(frames, *drift))
            self.resyncs += 1
            now = self.buffer.sample(t)
        planned = velocity  # what the planner is asked for
        if self.follower is not None and not hold:  # the legs walk the robot to the target, the planner walks the plan there
            velocity = self.follower.command(state)
            planned = self.follower.plan_command(now.qpos, self.cfg.locomotion.spring)
        changed = self._last_command is None or _differs(planned, self._last_command, self.cfg.command_change)
        asked = gestures if gestures is not None else ((gesture,) if gesture else ())
        changed = self.locomotion.set_gestures(asked, t) or changed
        if changed:
            self._last_command = planned
        self.locomotion.command = planned
        crossfade = None
        if self._segment_start is not None:
            (crossfade, with_context), self._segment_start = self._segment_start, None
            self._fresh_context, changed = not with_context, True
        self.scheduler.update(t, replan_now=changed, crossfade_frames=crossfade)
        return ReferenceWindow(
            t,
            velocity,
            plan=now,
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
            "plan_resyncs": self.resyncs,
        } | (self.follower.report() if self.follower is not None else {})

    def close(self) -> None:
        self.scheduler.close()

    def _drift(self, planned: FloatArray, state: RobotState) -> tuple[FloatArray, FloatArray] | None:
        """(planned, measured) root poses when they are further apart than the resync thresholds."""
        plan_pose = np.array([planned[0], planned[1], float(quat.heading(planned[g1.QPOS_ROOT_QUAT]))])
        measured = np.array([state.base_pos[0], state.base_pos[1], float(quat.heading(state.base_quat))])
        far = math.hypot(*(measured[:2] - plan_pose[:2])) > self.cfg.resync_distance_m
        turned = abs(float(quat.wrap_angle(measured[2] - plan_pose[2]))) > self.cfg.resync_heading_rad
        return (plan_pose, measured) if far or turned else None


def shift_frames(frames: FloatArray, source: FloatArray, target: FloatArray) -> FloatArray:
    """`frames` (qpos [K, 36]) moved rigidly about z so that root pose `source` (x, y, heading) lands on `target`."""
    turn = float(quat.wrap_angle(target[2] - source[2]))
    c, s = math.cos(turn), math.sin(turn)
    out = np.array(frames, dtype=np.float64)
    rel = out[:, :2] - source[:2]
    out[:, 0] = target[0] + c * rel[:, 0] - s * rel[:, 1]
    out[:, 1] = target[1] + s * rel[:, 0] + c * rel[:, 1]
    out[:, g1.QPOS_ROOT_QUAT] = quat.multiply(quat.from_yaw(turn), out[:, g1.QPOS_ROOT_QUAT])
    return out


def standing_context(last: FloatArray) -> FloatArray:
    """A context of 4 frames standing still in the default pose where `last` (qpos [36]) has its root (x, y, heading)."""
    frame = np.array(g1.standing_qpos())
    frame[:2] = last[:2]
    frame[g1.QPOS_ROOT_QUAT] = quat.from_yaw(float(quat.heading(last[g1.QPOS_ROOT_QUAT])))
    return np.tile(frame, (CONTEXT_FRAMES, 1))


def _differs(a: VelocityCommand, b: VelocityCommand, tol: float) -> bool:
    return math.hypot(a.vx - b.vx, a.vy - b.vy) > tol or abs(a.yaw_rate - b.yaw_rate) > tol
