"""The replanning scheduler: plans asked for at 10 Hz off the control loop, spliced into the reference buffer.

Every control tick calls `update(t, replan_now)`. The scheduler then

- takes in the plan in flight when it is ready: checked (finite, the expected shape),
  joint angles clamped to the limits, and spliced into the buffer at the time it was
  asked for, a short look-ahead after the request, with a cross-fade; a plan that comes
  back after that time is dropped and counted as late;
- asks for the next plan when the period has passed or the caller says the command
  changed (one plan in flight at a time), with the context read from the buffer being
  executed at the splice time, so the new plan continues what the robot will be doing.

Plans run on a worker thread, or in a planner that takes requests on the caller's thread
(`submit`: `PlannerProcess.submit`, the planner in a process of its own, as the real-time
clock wants it: a plan in this process shares the interpreter lock with the loop), so a tick
never waits for one on the real-time clock. A plan's latency is the wall time from its request
to its return, stamped as it returns: the tick that takes it in comes up to a control period
later, but the plan is used at its splice time whichever tick takes it in. On the
simulated clock a plan becomes available a configured latency after its request, in
simulated time, whatever the machine's speed: the loop waits for the worker right at the
request (simulated time stands still meanwhile, and nothing else competes for the cores,
so the recorded latency is the plan's own cost), and runs stay reproducible for a seed.

A planner that raises, returns NaN or stalls past `stall_timeout_s` is a failure: it is
logged and counted, the buffer being executed runs out, and the reference then holds
its last pose (the tracker stands). A later plan may recover.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, field

import numpy as np

from controller.planner.plausibility import JOINT_LOWER, JOINT_UPPER, wild_frames
from controller.planner.request import FPS, Plan, PlanRequest
from controller.reference.buffer import ReferenceBuffer
from hw import g1
from hw.errors import ConfigError
from hw.types import FloatArray

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SchedulerConfig:
    period_s: float = 0.1  # replanning period (10 Hz)
    lookahead_s: float = 0.1  # a plan is spliced this long after it was asked for: its deadline
    crossfade_frames: int = 3  # frames of the new plan blended into the old one at the splice
    simulated_latency_s: float = 0.02  # simulated clock: a plan is ready this long after its request
    stall_timeout_s: float = 1.0  # wall seconds a plan may take before it counts as failed
    # A plan whose pelvis tilts further than this, or whose height moves more than this within the plan, is a
    # failure, not a reference: before context tilts were capped (`LocomotionConfig.max_context_tilt_deg`) a
    # drifting context took the shipped planner's plans to 177 degrees and the root to 1e13 m. Sound plans on
    # `random_commands` (120 s, seed 1): at most 31 degrees and 0.29 m, mid-plan; their first 6 frames 18 degrees.
    max_root_tilt_deg: float = 90.0
    max_root_height_change_m: float = 0.4

    def __post_init__(self) -> None:
        for name in ("period_s", "lookahead_s", "stall_timeout_s"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"scheduler {name} must be positive, got {getattr(self, name)}")
        if not 0 <= self.simulated_latency_s < self.lookahead_s:
            raise ConfigError(
                f"scheduler simulated_latency_s ({self.simulated_latency_s}) must be in [0, lookahead_s = {self.lookahead_s}): "
                "a plan slower than the look-ahead is always late"
            )
        if self.crossfade_frames < 0:
            raise ConfigError(f"scheduler crossfade_frames must be >= 0, got {self.crossfade_frames}")
        if not 0 < self.max_root_tilt_deg <= 180 or not self.max_root_height_change_m > 0:
            raise ConfigError(
                f"scheduler max_root_tilt_deg must be in (0, 180] and max_root_height_change_m positive, "
                f"got {self.max_root_tilt_deg} and {self.max_root_height_change_m}"
            )


@dataclass
class SchedulerCounters:
    requests: int = 0
    replans: int = 0  # plans spliced into the buffer
    late_plans: int = 0  # plans that came back after their splice time: dropped
    planner_failures: int = 0  # raised, NaN, wrong shape, stalled
    # Of every plan that came back finite and of the right shape, spliced or not (what the planner produced):
    planned_frames: int = 0
    joint_values_beyond_limits: int = 0  # joint angles outside the limits, before the clamp (all that the clamp changes)
    wild_frames: int = 0  # frames beyond what the motion data ever shows (`plausibility.wild_frames`)
    unreachable_targets: int = 0  # plans that say a keyframe was out of reach (`Plan.unreachable`)


@dataclass(frozen=True)
class _InFlight:
    future: Future[tuple[Plan, float]]  # the plan and the wall time (perf_counter) it came back at
    requested_at: float  # run time of the request
    splice_time: float  # run time of the plan's first frame
    ready_at: float | None  # simulated clock: when the plan becomes available; None on the real-time clock
    submitted_wall: float
    start: FloatArray  # the context's last frame: where the plan starts from
    cost_s: float | None = None  # simulated clock: wall seconds until the wait for the plan ended (None: it stalled)
    crossfade_frames: int = 3  # how the plan is blended into the buffer at its splice
    moves: list[Callable[[FloatArray], FloatArray]] = field(default_factory=list)  # buffer moves since the request


class ReplanScheduler:
    """Keeps `buffer` filled with plans from `plan`, asked for with requests from `make_request`.

    `make_request(context, splice_time)` builds the request for a plan whose frames follow
    `context` (the last 4 frames of the buffer at `splice_time`): the command, targets and
    keyframes are the caller's. `joint_limits` (lower, upper) in joint order clamp every plan (None: none is clamped,
    and joint values are counted against the G1's own limits). `submit`: the same planner taking a request on the
    caller's thread and answering later (None: `plan` runs on the worker thread).
    """

    def __init__(
        self,
        plan: Callable[[PlanRequest], Plan],
        make_request: Callable[[FloatArray, float], PlanRequest],
        buffer: ReferenceBuffer,
        cfg: SchedulerConfig = SchedulerConfig(),
        simulated_clock: bool = True,
        joint_limits: tuple[FloatArray, FloatArray] | None = None,
        submit: Callable[[PlanRequest], Future[Plan]] | None = None,
    ) -> None:
        self._plan = plan
        self._submit = submit
        self._make_request = make_request
        self.buffer = buffer
        self.cfg = cfg
        self.simulated_clock = simulated_clock
        self._limits = None if joint_limits is None else (np.asarray(joint_limits[0], float), np.asarray(joint_limits[1], float))
        self.counters = SchedulerCounters()
        self.plan_latencies_s: list[float] = []  # real cost of every plan that came back
        self.last_failure: str | None = None
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="planner")
        self._in_flight: _InFlight | None = None
        self._next_request = -math.inf

    def update(self, t: float, replan_now: bool = False, crossfade_frames: int | None = None) -> None:
        """One control tick at run time `t`: take in a finished plan, ask for the next one when due.

        `crossfade_frames`: the blend of the plan asked for on this tick, if one is (None: the configured one);
        a longer overlap joins two clauses of a text plan.
        """
        if self._in_flight is not None:
            self._collect(t)
        if self._in_flight is None and (replan_now or t >= self._next_request - 1e-9):
            self._request(t, self.cfg.crossfade_frames if crossfade_frames is None else crossfade_frames)

    def move(self, transform: Callable[[FloatArray], FloatArray]) -> None:
        """Move everything the buffer holds (`ReferenceBuffer.move`), and the plan in flight with it when it comes back.

        That plan continues the context as it was at its request: spliced unmoved onto a moved
        buffer, its crossfade would carry the reference across the move in 0.1 s (a 0.1 m
        re-anchoring read as 1 m/s of extra speed).
        """
        self.buffer.move(transform)
        if self._in_flight is not None:
            self._in_flight.moves.append(transform)

    def _request(self, t: float, crossfade_frames: int) -> None:
        splice_time = t + self.cfg.lookahead_s
        try:
            request = self._make_request(self.buffer.context(splice_time), splice_time)
        except Exception as exc:  # a request that cannot be built is a planner failure, not a crash
            self._fail(f"cannot build the plan request: {exc}")
            self._next_request = t + self.cfg.period_s
            return
        ready_at = t + self.cfg.simulated_latency_s if self.simulated_clock else None
        submitted = time.perf_counter()
        try:
            future = _stamped(self._submit(request) if self._submit is not None else self._executor.submit(self._plan, request))
        except RuntimeError as exc:  # the worker (or the planner process) is gone: count it, plan on a fresh one next time
            self._fail(f"the planner worker is gone ({exc})")
            self._restart_worker()
            self._next_request = t + self.cfg.period_s
            return
        cost = None
        if ready_at is not None and wait([future], timeout=self.cfg.stall_timeout_s).done:
            cost = time.perf_counter() - submitted
        self._in_flight = _InFlight(future, t, splice_time, ready_at, submitted, request.context[-1], cost, crossfade_frames)
        self.counters.requests += 1
        self._next_request = t + self.cfg.period_s

    def _collect(self, t: float) -> None:
        flight = self._in_flight
        assert flight is not None
        if flight.ready_at is not None:  # simulated clock: the plan was waited for at the request
            if t < flight.ready_at - 1e-9:
                return
            if flight.cost_s is None:
                self._in_flight = None
                self._fail(f"the planner stalled (no plan after {self.cfg.stall_timeout_s} s)")
                self._restart_worker()
                return
        elif not flight.future.done():
            if time.perf_counter() - flight.submitted_wall > self.cfg.stall_timeout_s:
                self._in_flight = None
                self._fail(f"the planner stalled (no plan after {self.cfg.stall_timeout_s} s)")
                self._restart_worker()
            return
        self._in_flight = None
        error = flight.future.exception()
        if error is not None:
            self.plan_latencies_s.append(flight.cost_s if flight.cost_s is not None else time.perf_counter() - flight.submitted_wall)
            self._fail(f"the planner raised {type(error).__name__}: {error}")
            return
        plan, returned_wall = flight.future.result()
        self.plan_latencies_s.append(returned_wall - flight.submitted_wall)
        frames = self._checked(plan, flight.start)
        if frames is None:
            return
        for transform in flight.moves:
            frames = transform(frames)
        arrival = t if flight.ready_at is None else flight.ready_at
        if arrival > flight.splice_time + 1e-9:
            self.counters.late_plans += 1
            log.warning(
                "plan asked for at %.3f s came back at %.3f s, after its splice time %.3f s: dropped",
                flight.requested_at,
                t,
                flight.splice_time,
            )
            return
        self.buffer.splice(frames, flight.splice_time + 1.0 / FPS, flight.crossfade_frames)
        self.counters.replans += 1

    def _checked(self, plan: Plan, start: FloatArray) -> FloatArray | None:
        """The plan's frames ready to splice, counted (limits, wild frames) and clamped; None when it is a failure."""
        frames = np.asarray(plan.qpos, dtype=np.float64)
        if frames.ndim != 2 or frames.shape[1] != g1.QPOS_SIZE or len(frames) == 0:
            self._fail(f"the planner returned frames of shape {list(frames.shape)}, expected [N, {g1.QPOS_SIZE}]")
            return None
        if not np.isfinite(frames).all():
            self._fail("the planner returned NaN or infinite values")
            return None
        c = self.counters
        c.planned_frames += len(frames)
        c.wild_frames += int(np.count_nonzero(wild_frames(frames, start)))
        if plan.unreachable is not None:
            c.unreachable_targets += 1
            log.warning("plan asked for a target out of reach: %s", plan.unreachable)
        joints = frames[:, g1.QPOS_JOINTS]
        lower, upper = self._limits if self._limits is not None else (JOINT_LOWER, JOINT_UPPER)
        clamped = np.clip(joints, lower, upper)
        c.joint_values_beyond_limits += int(np.count_nonzero(clamped != joints))
        implausible = implausible_root(frames, self.cfg.max_root_tilt_deg, self.cfg.max_root_height_change_m)
        if implausible is not None:
            self._fail(f"the planner returned an implausible root: {implausible}")
            return None
        if self._limits is not None:
            frames[:, g1.QPOS_JOINTS] = clamped
        return frames

    def _fail(self, reason: str) -> None:
        self.counters.planner_failures += 1
        self.last_failure = reason
        log.warning("planner failure %d: %s; the reference runs out, then holds its last pose", self.counters.planner_failures, reason)

    def _restart_worker(self) -> None:
        """A stalled plan keeps its thread busy: leave it behind and plan on a fresh worker."""
        self._executor.shutdown(wait=False, cancel_futures=True)
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="planner")

    def close(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)


def _stamped(future: Future[Plan]) -> Future[tuple[Plan, float]]:
    """The plan and the wall time (perf_counter) it came back at, stamped where it comes back: the tick that takes it in may
    come a control period later."""
    stamped: Future[tuple[Plan, float]] = Future()

    def returned(done: Future[Plan]) -> None:
        if done.cancelled():
            stamped.cancel()
        elif (error := done.exception()) is not None:
            stamped.set_exception(error)
        else:
            stamped.set_result((done.result(), time.perf_counter()))

    future.add_done_callback(returned)
    return stamped


def implausible_root(frames: FloatArray, max_tilt_deg: float, max_height_change_m: float) -> str | None:
    """What is wrong with the root of plan `frames` (qpos [N, 36]): tilted too far, or rising or sinking too much; None when fine.

    The height is judged by its change within the plan: without a base position estimate (hardware) it is the plan's own.
    """
    q = frames[:, g1.QPOS_ROOT_QUAT] / np.linalg.norm(frames[:, g1.QPOS_ROOT_QUAT], axis=1, keepdims=True)
    up = 1.0 - 2.0 * (q[:, 1] ** 2 + q[:, 2] ** 2)  # the body z axis's world z component: cos(tilt)
    tilt = float(np.degrees(np.arccos(np.clip(up.min(), -1.0, 1.0))))
    if tilt > max_tilt_deg:
        return f"pelvis tilted {tilt:.0f} degrees (at most {max_tilt_deg:g})"
    change = float(np.ptp(frames[:, 2]))
    if change > max_height_change_m:
        return f"pelvis height moved {change:.2f} m within the plan (at most {max_height_change_m:g})"
    return None
