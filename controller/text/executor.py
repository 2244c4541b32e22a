"""Executing a behaviour program: clause after clause through the planner in the loop, corrected on the way.

`TextReference` is a reference source: the session ticks it like any other. It runs the
clauses in order on top of a `PlannedReference` (10 Hz replanning, the reference buffer,
the gesture library):

- A clause with a base motion gets a `WaypointFollower` on its waypoints; the legs follow
  the measured root to them and the planner walks its own root there (waypoints mode).
  A clause without one stands where it is (no follower: the plan stays put under a robot
  that sways with raised arms, see `PlannedReference`).
- Gestures are upper-body edits on whatever the base motion does (CoMA's body-part split):
  the gesture library's arm keyframes, layered on each plan.
- Self-correction: each clause's targets are placed from the pose the program *intended*
  at its start (the composition of the earlier clauses' goals), not from where the robot
  happens to stand, and the follower closes the loop on the measured root. A clause that
  ended 5 cm short is made good by the next one: errors do not accumulate.
- Composition: at each boundary the next clause's first plan is asked for at once, with
  the executed motion as its context, and blended into it over `blend_frames` frames
  (Text2BFM-Compose's overlap). Two baselines it is judged against: `continue_motion=False`
  plans the next clause from a standing pose and crossfades it over the same frames, and
  `blend_frames=None` concatenates naively (from a standing pose, no blend).
- The clause's text conditions the planner's text slot, when the planner was trained so.
- Arms no gesture of the clause moves are held down (`hold_free_arms`): an instruction that
  names no arm gets no arm motion beyond what the walk needs.
- Corrected on what was done: when a clause is over, what the robot did is compared, in the
  controller's own view (never the simulator's truth), with what was asked: where it ended
  against the clause's intended end pose, and the gestures a detector sees in its measured arm
  motion against the clause's gestures. Outside `correct_position_m` / `correct_heading_deg`, or
  with an asked gesture not seen, the clause goes on with a correction (a re-approach of the end
  pose, the gestures held `GESTURE_REDO_S` more), at most `max_corrections` times. Each
  correction, its reason and its times are in the clause's record.

A clause ends when its follower has settled on the last target and its minimum duration
has passed, or, failing that, after a timeout (reported). Everything measured per clause
(start and end pose, unwrapped heading change, the executed frames) is kept for the
report, in two views: the controller's own state (what it steered by: the estimate on
hardware), and the simulator's truth at the same tick where one stands behind the robot
(`truth`), which judges the run. A program that walks or turns needs the base's position:
on a robot whose state has none (`RobotState.has_base_position`) it is refused at the start.
No MuJoCo, no torch.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from controller.commands.velocity import ZERO, CommandLimits, VelocityCommand
from controller.commands.waypoints import WorldWaypoint
from controller.reference.curves import CurveFollower
from controller.reference.planned import PlannedReference
from controller.reference.source import ReferenceSource
from controller.reference.waypoints import Follower, WaypointConfig, WaypointFollower
from controller.reference.window import ReferenceWindow
from controller.text.program import Clause, Curve, Program, library_gesture
from hw import g1, quat
from hw.errors import ConfigError
from hw.types import FloatArray, RobotState

Pose = tuple[float, float, float]  # x, y (m, world), heading (rad, unwrapped)
# Slowing down inside the follower's slow radius, then settling (at rest for 0.3 s): measured on
# "walk forward half a meter and back, twice", four waypoints took 2-2.5 s each beyond path / speed.
SETTLE_PER_WAYPOINT_S = 2.0
YAW_RATE_AT_FINISH = 0.8  # rad/s: a curve's end pose is settled at the clause's default turning rate
GESTURE_REDO_S = 3.0  # a gesture not seen in the clause is held on this much longer (a gesture alone lasts 3 s)
DETECT_FRAMES = 500  # a clause's gestures are looked for in at most its last 500 measured frames (10 s at 50 Hz)


def _clause_waypoints() -> WaypointConfig:
    """The waypoints mode's follower, a little less exacting: a clause is there within 8 cm and 4 degrees.

    Measured: walking backward at the 0.1 m/s floor the locomotion policy barely moves, and a
    clause ended 5.0 cm short of a 5 cm tolerance waited for its timeout. The next clause's
    targets are placed from the intended pose, so what is left over is made good there.
    """
    return WaypointConfig(position_tolerance=0.08, stop_radius=0.06, heading_tolerance_deg=4.0, stop_angle_deg=2.5)


@dataclass(frozen=True)
class TextRunConfig:
    blend_frames: int | None = 8  # overlap of two clauses' plans (frames at 30 fps); None: naive concatenation
    continue_motion: bool = True  # the next clause's plan continues the executed motion; False: the crossfade baseline
    timeout_factor: float = 1.5  # a clause may take this many times its estimate, plus the margin, before it is given up
    timeout_margin_s: float = 5.0
    hold_free_arms: bool = True  # arms no clause gesture moves stay down (see `SmartLocomotion.hold_free_arms`)
    waypoints: WaypointConfig = field(default_factory=_clause_waypoints)
    max_corrections: int = 1  # per clause; 0: none
    # A clause that ended further than this from its intended end pose is corrected: twice the follower's
    # tolerance (it settles within 0.08 m and 4 degrees), well inside a person's 0.35 m and 20 degrees.
    correct_position_m: float = 0.15
    correct_heading_deg: float = 10.0

    def __post_init__(self) -> None:
        if self.blend_frames is not None and self.blend_frames < 1:
            raise ConfigError(f"blend_frames must be at least 1 (or None for naive concatenation), got {self.blend_frames}")
        if self.max_corrections < 0 or self.correct_position_m <= 0 or self.correct_heading_deg <= 0:
            raise ConfigError(
                f"max_corrections must be at least 0 and the correction tolerances positive, got {self.max_corrections}, "
                f"{self.correct_position_m} m, {self.correct_heading_deg} degrees"
            )


@dataclass
class PoseTrack:
    """Where the robot went during one clause, as one view saw it: the controller's state, or the simulator's truth."""

    start_pose: Pose
    has_position: bool  # False: this view has no base position (it reads zero), only its heading counts
    end_pose: Pose | None = None
    heading_change: float = 0.0  # rad, unwrapped, positive to the left
    last_heading: float = 0.0  # wrapped, for unwrapping

    @classmethod
    def begin(cls, state: RobotState) -> PoseTrack:
        pose = _pose(state)
        return cls(pose, state.has_base_position, last_heading=pose[2])

    def measure(self, state: RobotState) -> None:
        heading = float(quat.heading(state.base_quat))
        self.heading_change += float(quat.wrap_angle(heading - self.last_heading))
        self.last_heading = heading

    def end(self, state: RobotState) -> None:
        self.end_pose = _pose(state)

    @property
    def displacement(self) -> tuple[float, float] | None:
        """(forward, left) in metres, in the frame of the robot at the clause's start; None without a base position."""
        if not self.has_position:
            return None
        if self.end_pose is None:
            return (0.0, 0.0)
        return to_frame(self.start_pose, self.end_pose[:2])


@dataclass
class ClauseRecord:
    """What happened while one clause ran (times in seconds from the run's start)."""

    index: int
    clause: Clause
    start_s: float
    estimate: PoseTrack  # the controller's own view, what it steered by: the estimate on hardware (on the simulator, the truth)
    intended_start: Pose  # where the program meant this clause to start (in the controller's view)
    truth: PoseTrack | None = None  # the simulator's truth over the same ticks; None: no simulator behind the robot
    end_s: float | None = None
    timed_out: bool = False
    interrupted: bool = False  # ended early by a new instruction or a stop (`TextReference.replace_program`)
    frames: list[FloatArray] = field(default_factory=list)  # executed qpos [36], one per tick, in the judged view
    reference: list[FloatArray] = field(default_factory=list)  # the planned reference's qpos [36], one per tick
    intended_end: Pose | None = None  # where the program meant this clause to end (the controller's view)
    phase_start_s: float = 0.0  # when the clause, or its latest correction, began
    phase_min_s: float = 0.0  # ... and how long that phase lasts at least
    corrections: list[dict[str, Any]] = field(default_factory=list)  # reason, start_s, end_s of each
    own_frames: list[FloatArray] = field(default_factory=list)  # measured qpos [36] in the controller's view: what it corrects by

    @property
    def judged(self) -> PoseTrack:
        """The view the report judges by: the truth where a simulator stands behind the robot, else the controller's."""
        return self.truth if self.truth is not None else self.estimate


def to_frame(origin: Pose, point: tuple[float, float] | Pose) -> tuple[float, float]:
    """`point` (x, y world) in the frame of `origin` (forward, left)."""
    dx, dy = point[0] - origin[0], point[1] - origin[1]
    c, s = math.cos(origin[2]), math.sin(origin[2])
    return (c * dx + s * dy, -s * dx + c * dy)


def from_frame(origin: Pose, forward: float, left: float, turn_rad: float) -> Pose:
    """The pose `forward`, `left` (m) and `turn_rad` from `origin`, in the world."""
    c, s = math.cos(origin[2]), math.sin(origin[2])
    return (origin[0] + c * forward - s * left, origin[1] + s * forward + c * left, origin[2] + turn_rad)


def estimate_seconds(clause: Clause, intended_start: Pose, pose: Pose) -> float:
    """How long the clause should take from `pose`: its path at its speed, its turns at its rate, at least its minimum duration."""
    if clause.motion is None:
        return clause.min_duration_s
    if isinstance(clause.motion, Curve):
        along = clause.motion.length_m + math.hypot(intended_start[0] - pose[0], intended_start[1] - pose[1])
        return max(along / clause.motion.speed_mps + SETTLE_PER_WAYPOINT_S, clause.min_duration_s)
    motion, seconds, here = clause.motion, 0.0, pose
    for w in motion.waypoints:
        target = from_frame(intended_start, w.forward_m, w.left_m, math.radians(w.heading_deg))
        seconds += math.hypot(target[0] - here[0], target[1] - here[1]) / motion.speed_mps
        seconds += abs(target[2] - here[2]) / motion.yaw_rate
        seconds += SETTLE_PER_WAYPOINT_S
        here = target
    return max(seconds, clause.min_duration_s)


class TextReference(ReferenceSource):
    """Runs a `Program` clause by clause on a `PlannedReference`; `records` hold what each clause did."""

    def __init__(
        self,
        program: Program,
        planned: PlannedReference,
        cfg: TextRunConfig = TextRunConfig(),
        limits: CommandLimits | None = None,
        embed: Callable[[str], FloatArray] | None = None,  # clause text -> the planner's text embedding; None: no text
        truth: Callable[[], RobotState | None] | None = None,  # the simulator's truth at the tick (`Backend.truth`)
        detect: Callable[[FloatArray, float], tuple[str, ...]] | None = None,  # measured qpos [T, 36], Hz -> gestures seen
    ) -> None:
        self.program = program
        self.detect = detect
        self.truth = truth
        self.planned = planned
        self.cfg = cfg
        self.limits = limits
        self.embed = embed
        self.records: list[ClauseRecord] = []
        self.finished_at: float | None = None  # run time the last clause ended
        self.now = 0.0  # run time of the latest tick
        self._t0 = 0.0
        self._intended: Pose = (0.0, 0.0, 0.0)
        self._deadline = math.inf
        # A program that walks or turns steers to positions: a failed state estimate stands it (a gesture-only one goes on).
        self.needs_base_position = any(clause.motion is not None for clause in program.clauses)

    @property
    def current(self) -> ClauseRecord | None:
        """The record of the clause running now (None before the start and once all are done)."""
        return self.records[-1] if self.records and self.records[-1].end_s is None else None

    @property
    def caption(self) -> str:
        """What a video shows: the clause running now."""
        current = self.current
        if current is not None:
            return f"{current.index + 1}/{len(self.program.clauses)}: {current.clause.text}"
        return "done" if self.finished_at is not None else ""

    def start(self, state: RobotState) -> None:
        _check_position(self.program, state)
        self.planned.locomotion.hold_free_arms = self.cfg.hold_free_arms
        self.planned.start(state)
        if self.records:  # a restart after a fall: the clause running goes on from where the robot is
            return
        self._t0 = state.time
        self._intended = _pose(state)
        self._begin(0, state, self._truth())

    def finished_for(self, seconds: float) -> bool:
        """The last clause ended at least `seconds` ago (the robot has had time to come to rest)."""
        return self.finished_at is not None and self.now - self.finished_at >= seconds - 1e-9

    def window(self, state: RobotState, velocity: VelocityCommand, gesture: str = "", hold: bool = False) -> ReferenceWindow:
        self.now = state.time - self._t0
        current = self.current
        if current is not None and not hold:
            truth = self._truth()
            self._measure(current, state, truth)
            if self._clause_over(current, state):
                reason = self._correction_needed(current, state)
                if reason is not None:
                    self._correct(current, state, reason)
                else:
                    self._finish(current, state, truth)
        running = self.current
        if running is not None:  # every arm track of the clause (CoMA's body-part split)
            tracks = tuple(library_gesture(g) for g in running.clause.gestures)
            window = self.planned.window(state, ZERO, hold=hold, gestures=tracks)
        else:
            window = self.planned.window(state, velocity, gesture, hold)
        if running is not None and window.plan is not None:
            running.reference.append(np.array(window.plan.qpos))
        return window

    def _finish(self, record: ClauseRecord, state: RobotState, truth: RobotState | None) -> None:
        """The clause is over (and corrected where it needed to be): the next one begins, or the program is done."""
        if record.corrections and "end_s" not in record.corrections[-1]:
            record.corrections[-1]["end_s"] = round(state.time - self._t0, 4)
        self._end(record, state, truth)
        if record.index + 1 < len(self.program.clauses):
            self._begin(record.index + 1, state, truth)
        else:
            self.finished_at = state.time - self._t0
            self.planned.follower = None
            self.planned.locomotion.text_embedding = None

    def _correction_needed(self, record: ClauseRecord, state: RobotState) -> str | None:
        """Why the clause just over must be corrected (None: it did what was asked, or its corrections are used up)."""
        cfg = self.cfg
        if record.corrections:
            record.corrections[-1]["end_s"] = round(state.time - self._t0, 4)
        if len(record.corrections) >= cfg.max_corrections:
            return None
        problems = []
        # Only a clause that moves is re-approached: one that stands (a gesture, a pause) steers to no position, and goes on
        # where the estimate of it has failed (hanging in a gantry the legs step in the air and the estimate drifts off).
        if record.clause.motion is not None and record.intended_end is not None and state.has_base_position:
            pose = _pose(state)
            miss = math.hypot(pose[0] - record.intended_end[0], pose[1] - record.intended_end[1])
            turn = math.degrees(abs(float(quat.wrap_angle(pose[2] - record.intended_end[2]))))
            if miss > cfg.correct_position_m or turn > cfg.correct_heading_deg:
                problems.append(f"ended {miss:.2f} m and {turn:.0f} degrees from its goal")
        asked = set(record.clause.gestures)
        if self.detect is not None and asked and len(record.own_frames) > 1:
            # A clause's gestures are in force to its end: its last frames show them, and the detector's cost (about
            # 7 ms for 500 frames) stays bounded on a control thread however long the clause was.
            frames = record.own_frames[-DETECT_FRAMES:]
            seconds = (state.time - self._t0 - record.start_s) * len(frames) / len(record.own_frames)
            seen = set(self.detect(np.array(frames), (len(frames) - 1) / max(seconds, 1e-6)))
            if asked - seen:
                problems.append(f"gestures {sorted(asked - seen)} not seen")
        return "; ".join(problems) or None

    def _correct(self, record: ClauseRecord, state: RobotState, reason: str) -> None:
        """Go on with the clause: re-approach its end pose where it is off, hold its gestures on where one was not seen."""
        t = state.time - self._t0
        record.corrections.append({"reason": reason, "start_s": round(t, 4), "after_timeout": record.timed_out})
        record.phase_start_s = t
        record.phase_min_s = GESTURE_REDO_S if "gestures" in reason else 0.0
        follower: Follower | None = None
        seconds = record.phase_min_s
        if "from its goal" in reason and record.intended_end is not None:
            x, y, h = record.intended_end
            motion = record.clause.motion
            speed, yaw_rate = (motion.speed_mps, getattr(motion, "yaw_rate", YAW_RATE_AT_FINISH)) if motion else (0.5, YAW_RATE_AT_FINISH)
            follower = WaypointFollower(
                [WorldWaypoint(x, y, math.degrees(h))], _with_rates(self.cfg.waypoints, speed, yaw_rate), self.limits
            )
            follower.start(state)
            pose = _pose(state)
            seconds += math.hypot(x - pose[0], y - pose[1]) / speed + abs(float(quat.wrap_angle(h - pose[2]))) / yaw_rate
            seconds += SETTLE_PER_WAYPOINT_S
        self.planned.follower = follower
        record.timed_out = False
        self._deadline = t + self.cfg.timeout_factor * seconds + self.cfg.timeout_margin_s

    def _truth(self) -> RobotState | None:
        return self.truth() if self.truth is not None else None

    def _begin(self, index: int, state: RobotState, truth: RobotState | None) -> None:
        clause = self.program.clauses[index]
        t = state.time - self._t0
        truth_track = PoseTrack.begin(truth) if truth is not None else None
        record = ClauseRecord(index, clause, round(t, 4), PoseTrack.begin(state), self._intended, truth_track)
        follower: Follower | None = None
        if isinstance(clause.motion, Curve):
            arcs = [(arc.radius_m, math.radians(arc.angle_deg)) for arc in clause.motion.arcs]
            finish = _with_rates(self.cfg.waypoints, clause.motion.speed_mps, YAW_RATE_AT_FINISH)
            follower = CurveFollower(self._intended, arcs, clause.motion.speed_mps, finish, self.limits)
            follower.start(state)
            end = clause.motion.end
            self._intended = from_frame(self._intended, end.forward_m, end.left_m, math.radians(end.heading_deg))
        elif clause.motion is not None:
            waypoints = []
            for w in clause.motion.waypoints:
                x, y, h = from_frame(self._intended, w.forward_m, w.left_m, math.radians(w.heading_deg))
                waypoints.append(WorldWaypoint(x, y, math.degrees(h)))
            cfg = _with_rates(self.cfg.waypoints, clause.motion.speed_mps, clause.motion.yaw_rate)
            follower = WaypointFollower(waypoints, cfg, self.limits)
            follower.start(state)
            end = clause.motion.end
            self._intended = from_frame(self._intended, end.forward_m, end.left_m, math.radians(end.heading_deg))
        record.intended_end = self._intended
        record.phase_start_s, record.phase_min_s = record.start_s, clause.min_duration_s
        self.planned.follower = follower
        self.planned.locomotion.text_embedding = self.embed(clause.text) if self.embed is not None else None
        if index > 0:
            self.planned.start_segment(self.cfg.blend_frames, self.cfg.continue_motion)
        self._deadline = t + self.timeout_s(clause, record.intended_start, record.estimate.start_pose)
        self.records.append(record)

    def replace_program(self, program: Program | None, state: RobotState) -> list[ClauseRecord]:
        """Switch to `program` at once, from where the robot is: an instruction given while it runs (`text/live.py`).

        The clause running ends, its record marked `interrupted`. The new program's first clause begins with its targets
        placed from the robot's pose now (not where the program replaced meant to be), and its first plan is asked for at
        once and blended into the executed motion, as at a clause boundary. None: nothing more runs (the plan stands where
        the robot is). Returns the records of the program replaced; `records` then holds the new one's. A program that
        walks, on a state with no base position, raises `ConfigError` with nothing changed. Times count from `start`, or,
        on a reference that never started (made over a planned reference already running), on the state's own clock.
        """
        if program is not None:
            _check_position(program, state)
        truth = self._truth()
        running = self.current
        if running is not None:
            running.interrupted = True
            if running.corrections and "end_s" not in running.corrections[-1]:
                running.corrections[-1]["end_s"] = round(state.time - self._t0, 4)
            self._end(running, state, truth)
        replaced, self.records = self.records, []
        if program is None:
            self.finished_at = state.time - self._t0
            self.planned.follower = None
            self.planned.locomotion.text_embedding = None
            return replaced
        self.program, self.finished_at = program, None
        self.needs_base_position = any(clause.motion is not None for clause in program.clauses)
        self.planned.locomotion.hold_free_arms = self.cfg.hold_free_arms
        self._intended = _pose(state)
        self._begin(0, state, truth)
        self.planned.start_segment(self.cfg.blend_frames, self.cfg.continue_motion)
        return replaced

    def timeout_s(self, clause: Clause, intended_start: Pose, pose: Pose) -> float:
        """How long the clause may run from `pose` before it is given up."""
        return self.cfg.timeout_factor * estimate_seconds(clause, intended_start, pose) + self.cfg.timeout_margin_s

    def _measure(self, record: ClauseRecord, state: RobotState, truth: RobotState | None) -> None:
        record.estimate.measure(state)
        if record.truth is not None and truth is not None:
            record.truth.measure(truth)
        judged = truth if truth is not None else state
        frame = np.empty(g1.QPOS_SIZE)
        frame[g1.QPOS_ROOT_POS] = judged.base_pos
        frame[g1.QPOS_ROOT_QUAT] = judged.base_quat
        frame[g1.QPOS_JOINTS] = judged.joint_pos
        record.frames.append(frame)
        if truth is None:
            record.own_frames.append(frame)
        else:  # the controller corrects by what it measures itself
            own = np.empty(g1.QPOS_SIZE)
            own[g1.QPOS_ROOT_POS], own[g1.QPOS_ROOT_QUAT], own[g1.QPOS_JOINTS] = state.base_pos, state.base_quat, state.joint_pos
            record.own_frames.append(own)

    def _clause_over(self, record: ClauseRecord, state: RobotState) -> bool:
        t = state.time - self._t0
        follower = self.planned.follower
        arrived = follower is None or follower.done
        if arrived and t - record.phase_start_s >= record.phase_min_s - 1e-9:
            return True
        if t >= self._deadline:
            record.timed_out = True
            return True
        return False

    def _end(self, record: ClauseRecord, state: RobotState, truth: RobotState | None) -> None:
        record.end_s = round(state.time - self._t0, 4)
        record.estimate.end(state)
        if record.truth is not None and truth is not None:
            record.truth.end(truth)

    def report(self) -> dict[str, Any]:
        return self.planned.report() | {
            "clauses_done": sum(r.end_s is not None for r in self.records),
            "corrections": sum(len(r.corrections) for r in self.records),
        }

    def close(self) -> None:
        self.planned.close()


def _check_position(program: Program, state: RobotState) -> None:
    """A program that walks or turns steers its base to positions: refused where the state has none (it reads zero)."""
    moving = next((clause for clause in program.clauses if clause.motion is not None), None)
    if moving is not None and not state.has_base_position:
        raise ConfigError(
            f"the text plan moves the base ('{moving.text}') to positions, but this robot's state has no base position estimate "
            "(the simulator gives it; on hardware the state estimator does)"
        )


def _pose(state: RobotState) -> Pose:
    return (float(state.base_pos[0]), float(state.base_pos[1]), float(quat.heading(state.base_quat)))


def _with_rates(cfg: WaypointConfig, speed: float, yaw_rate: float) -> WaypointConfig:
    """The follower's settings with the clause's speed and turning rate (never below its floors)."""
    return replace(cfg, max_speed=max(speed, cfg.min_speed), max_yaw_rate=max(yaw_rate, cfg.min_yaw_rate))
