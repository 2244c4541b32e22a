"""The planned reference: the command drives the planner, the tracker reads the plan buffer.

Each tick the supervised velocity command goes to smart locomotion, the scheduler asks
for plans (at 10 Hz, and at once on a meaningful command change) and the tracker gets a
`ReferenceWindow` with the plan sampled now and a little ahead. In the waypoints mode a
`WaypointFollower` gives both commands instead: the window's from the measured root (the
legs follow it), the planner's from the planned root, both towards the current target.
When the robot has fallen behind the plan (a policy that cannot reach the planned speed,
a push) by more than `resync_distance_m` or `resync_heading_rad`, the plan is re-anchored:
the whole buffer is moved rigidly (about z) towards where the robot is, a little each tick,
until it is within `reanchor_done_m` and `reanchor_done_rad` of it. Each tick's move is as
large as the reference can take without moving faster than the command allows (the spike
margins of `spikes.py`, less a reserve for the gait's own sway), and at most
`reanchor_speed_mps` and `reanchor_yaw_rate_radps`: pulled back onto a robot that lags, the
reference slows down, which is always allowed; pushed ahead, it may only speed up to the
margin. One jump instead (0.1 m in a 20 ms tick) read as 5 m/s. The next plans start from
the moved buffer, so the reference never runs away from the robot. Moving the whole buffer,
not only the next context, keeps it continuous: a context across a jump would read as a
burst of speed, and the spring would run the plan ahead. The arms' angles do not change;
the legs follow the command. No MuJoCo, no torch.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controller.commands.velocity import VelocityCommand
from controller.planner.request import CONTEXT_FRAMES, Plan, PlanRequest
from controller.reference.buffer import ReferenceBuffer, ReferenceSample
from controller.reference.locomotion import LocomotionConfig, SmartLocomotion
from controller.reference.scheduler import ReplanScheduler, SchedulerConfig
from controller.reference.skate import FootSkate, shipped_leg_chains
from controller.reference.source import ReferenceSource
from controller.reference.spikes import SpikeConfig, VelocitySpikes
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
    resync_distance_m: float = 0.1  # the plan's root this far from the measured root: it is re-anchored on the robot
    resync_heading_rad: float = 0.1  # ... or its heading this far off
    # A re-anchoring moves the plan this fast at most, and keeps the reference this far under the spike margins (room
    # for the gait's own sway), until the plan is this close to the robot.
    reanchor_speed_mps: float = 1.0
    reanchor_yaw_rate_radps: float = 1.0
    reanchor_reserve_mps: float = 0.15
    reanchor_reserve_radps: float = 0.3
    reanchor_done_m: float = 0.02
    reanchor_done_rad: float = 0.02
    spikes: SpikeConfig = field(default_factory=SpikeConfig)  # what counts as a velocity spike of the reference


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
        submit: Callable[[PlanRequest], Future[Plan]] | None = None,  # the planner taking requests on this thread (ReplanScheduler)
    ) -> None:
        self.cfg = cfg
        self.follower = follower
        self.buffer = ReferenceBuffer()
        self.locomotion = SmartLocomotion(cfg.locomotion, seed)
        self.scheduler = ReplanScheduler(plan, self._request, self.buffer, cfg.scheduler, simulated_clock, joint_limits, submit)
        self._last_command: VelocityCommand | None = None
        self.resyncs = 0  # re-anchorings started
        self._reanchoring = False
        self._last_tick: float | None = None
        self.spikes = VelocitySpikes(cfg.spikes)  # of the reference handed to the tracker, against the command planned for
        self.skate = FootSkate(shipped_leg_chains())  # ... and how fast its planted soles slide
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
        self.spikes.restart()
        self.skate.restart()
        self._reanchoring, self._last_tick = False, None
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
        dt, self._last_tick = (t - self._last_tick if self._last_tick is not None else 0.0), t
        step = self._reanchor_step(now, state, dt) if state.has_base_position and moving else None
        if step is not None:
            self.scheduler.move(lambda frames: shift_frames(frames, *step))
            now = self.buffer.sample(t)
        planned = velocity  # what the planner is asked for
        if self.follower is not None and not hold:  # the legs walk the robot to the target, the planner walks the plan there
            velocity = self.follower.command(state)
            planned = self.follower.plan_command(now.qpos, self.cfg.locomotion.spring)
        self.spikes.record(t, now.qpos, planned, self.locomotion.path_velocity(t))
        self.skate.record(t, now.qpos)
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
            "plan_joint_values_beyond_limits": c.joint_values_beyond_limits,
            "plan_wild_frames": c.wild_frames,
            "plan_wild_frame_share": round(c.wild_frames / c.planned_frames, 6) if c.planned_frames else 0.0,
            "plan_unreachable_targets": c.unreachable_targets,
            "plan_velocity_spikes": self.spikes.spikes,
            "plan_velocity_spike_share": round(self.spikes.share, 6),
            "plan_foot_skate_mps": round(self.skate.mean_mps, 4),
            "plan_resyncs": self.resyncs,
            "plan_resyncs_per_plan": round(self.resyncs / c.replans, 4) if c.replans else None,
        } | (self.follower.report() if self.follower is not None else {})

    def close(self) -> None:
        self.scheduler.close()

    def _reanchor_step(self, now: ReferenceSample, state: RobotState, dt: float) -> tuple[FloatArray, FloatArray] | None:
        """This tick's move of the plan towards the robot, as (from, to) root poses (x, y, heading); None: none is due.

        A re-anchoring starts when the plan is further from the robot than the resync thresholds
        and goes on, tick by tick, until the plan is within the done thresholds of it. Each step
        is the largest towards the robot that keeps the reference under the spike margins.
        """
        planned = now.qpos
        plan_pose = np.array([planned[0], planned[1], float(quat.heading(planned[g1.QPOS_ROOT_QUAT]))])
        measured = np.array([state.base_pos[0], state.base_pos[1], float(quat.heading(state.base_quat))])
        offset, turn = measured[:2] - plan_pose[:2], float(quat.wrap_angle(measured[2] - plan_pose[2]))
        distance = math.hypot(*offset)
        cfg = self.cfg
        if not self._reanchoring:
            if distance <= cfg.resync_distance_m and abs(turn) <= cfg.resync_heading_rad:
                return None
            self._reanchoring = True
            self.resyncs += 1
        if distance <= cfg.reanchor_done_m and abs(turn) <= cfg.reanchor_done_rad:
            self._reanchoring = False
            return None
        speed_limit, yaw_limit = self._allowed_rates(now.time)
        moved = np.zeros(2)
        if distance > 0:
            direction = offset / distance
            speed = pull_within(now.root_velocity[:2], direction, speed_limit - cfg.reanchor_reserve_mps, cfg.reanchor_speed_mps)
            moved = direction * min(distance, speed * dt)
        yaw_rate = pull_within(np.array([now.yaw_rate]), np.array([math.copysign(1.0, turn)]), yaw_limit - cfg.reanchor_reserve_radps,
                               cfg.reanchor_yaw_rate_radps)  # fmt: skip
        rotated = math.copysign(min(abs(turn), yaw_rate * dt), turn)
        return plan_pose, np.array([*(plan_pose[:2] + moved), plan_pose[2] + rotated])

    def _allowed_rates(self, t: float) -> tuple[float, float]:
        """The speed and yaw rate the reference may reach without a spike: the command's, or the root path's, plus the margins."""
        allowed = [self.locomotion.command]
        path = self.locomotion.path_velocity(t)
        if path is not None:
            allowed.append(path)
        margins = self.cfg.spikes
        return (
            max(math.hypot(c.vx, c.vy) for c in allowed) + margins.speed_margin_mps,
            max(abs(c.yaw_rate) for c in allowed) + margins.yaw_rate_margin_radps,
        )


def pull_within(velocity: FloatArray, direction: FloatArray, limit: float, most: float) -> float:
    """The largest speed s in [0, most] along unit `direction` with |velocity + s * direction| <= limit; where none fits
    (the plan alone is over the limit), the s that slows the reference most, if any."""
    along = float(velocity @ direction)
    discriminant = along * along - float(velocity @ velocity) + limit * limit
    if discriminant < 0 or limit <= 0:
        return float(np.clip(-along, 0.0, most))
    return float(np.clip(-along + math.sqrt(discriminant), 0.0, most))


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
