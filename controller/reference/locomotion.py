"""Smart locomotion requests: a velocity command becomes a plan request with a spring root target.

MotionBricks' primitive: from the root state at the end of the context and the command,
the critically damped spring of `root_spring` gives the root path over the next plan; the
planner is asked to meet its position and heading at the plan's last frame, and fills in
the whole-body motion (steps, arm swing) that gets there. Gestures in force (`set_gestures`, one
per arm) add arm keyframes over the plan (`gestures.py`), layered on whatever the legs do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from controller.commands.velocity import ZERO, VelocityCommand
from controller.planner.request import FPS, PlanRequest, target_root
from controller.reference.gestures import NONE_NAMES, Gesture, GestureConfig, GestureLibrary, merged
from controller.reference.root_spring import RootState, RootTrajectory, SpringConfig, root_state_from_frames, root_trajectory
from hw import g1, quat
from hw.errors import ConfigError
from hw.types import FloatArray


@dataclass(frozen=True)
class LocomotionConfig:
    plan_frames: int = 44  # 1.47 s at 30 fps: a multiple of 4 in 24-64 (the planner contract)
    spring: SpringConfig = field(default_factory=SpringConfig)
    gestures: GestureConfig = field(default_factory=GestureConfig)
    # Plans continue a context whose pelvis tilts at most this much (None: as planned). Each plan continues the
    # previous one's frames and nothing else holds the tilt: on `random_commands` the executed plans' pelvis
    # tilt reached 80 degrees, on a text plan's "turn around" 177 degrees and the root height 1e13 m.
    max_context_tilt_deg: float | None = 10.0

    def __post_init__(self) -> None:
        if self.plan_frames % 4 or not 24 <= self.plan_frames <= 64:
            raise ConfigError(f"plan_frames must be a multiple of 4 from 24 to 64, got {self.plan_frames}")


class SmartLocomotion:
    """Holds the command in force and turns a context into the next plan request (`request`)."""

    def __init__(self, cfg: LocomotionConfig = LocomotionConfig(), seed: int = 0) -> None:
        self.cfg = cfg
        self.command: VelocityCommand = ZERO
        self._seed = seed
        self._count = 0
        self.path: RootTrajectory | None = None  # the root path of the latest request
        self.path_start = 0.0  # run time of the path's frame 0 is path_start + 1/fps
        self._previous: tuple[RootTrajectory, float] | None = None  # the path before it, in force until its start
        self.library = GestureLibrary(cfg.gestures)
        self.gestures: tuple[Gesture, ...] = ()  # those in force (end inf) and those still blending out, by start
        self.text_embedding: FloatArray | None = None  # the planner's text conditioning (a text plan's clause), None: none
        # The arm joints no gesture moves stay on the base pose ("raise your right arm": the left one stays down;
        # "turn right": both). Off, the planner swings them as it likes: the shipped planner, half of whose training
        # windows are dance capture, raised the left arm too on "raise your right arm" in a text plan, and without
        # any text raised both arms during "turn right" after a walk (2026-12-02, detected as raise_both). Until
        # then they were held only while a gesture played: held through a turn in place, an earlier planner's
        # plans diverged; the shipped one turned in 5.9 s, settled, where free arms timed out at 11 s.
        self.hold_free_arms = False

    @property
    def gesture(self) -> Gesture | None:
        """The gesture in force last started (name and start time), None when none is."""
        in_force = [g for g in self.gestures if math.isinf(g.end)]
        return in_force[-1] if in_force else None

    @property
    def in_force(self) -> tuple[str, ...]:
        """The names of the gestures in force (not ending), in the order they started."""
        return tuple(g.name for g in self.gestures if math.isinf(g.end))

    def set_gesture(self, name: str, t: float) -> bool:
        """The one gesture asked for at run time `t` ("" or "none": none); see `set_gestures`."""
        return self.set_gestures(() if name in NONE_NAMES else (name,), t)

    def set_gestures(self, names: tuple[str, ...], t: float) -> bool:
        """The gestures asked for at run time `t`, one per arm (a text clause's arm tracks).

        A name not yet in force starts at `t`; one in force that is asked for again goes on
        (a pose held across clauses is not restarted); one no longer asked for ends at `t` and
        blends out. True when that changed anything: a plan asked for at once starts its blend
        on time.
        """
        wanted = tuple(dict.fromkeys(n for n in names if n not in NONE_NAMES))
        current = self.in_force
        if set(wanted) == set(current):
            return False
        for name in wanted:
            self.library.style(name)  # an unknown name fails here, naming the valid ones
        blend = self.cfg.gestures.blend_s
        ended = (replace(g, end=t) if math.isinf(g.end) and g.name not in wanted else g for g in self.gestures)
        kept = tuple(g for g in ended if g.alive(t, blend))
        self.gestures = kept + tuple(Gesture(name, t) for name in wanted if name not in current)
        return True

    def path_velocity(self, t: float) -> VelocityCommand | None:
        """The requested root path's velocity at run time `t`, in its heading frame: the latest path's from its start, the
        one before it until then (None: neither covers t)."""
        latest = (self.path, self.path_start) if self.path is not None else None
        for path, start in (p for p in (latest, self._previous) if p is not None):
            k = round((t - start) * FPS) - 1
            if 0 <= k < path.length:
                vx, vy = path.local_velocity(k)
                return VelocityCommand(vx, vy, float(path.yaw_rates[k]))
        return None

    def _continued(self, measured: RootState, splice_time: float) -> RootState:
        """The spring's rates carried over from the previous path (where it covers `splice_time`), at the context's pose.

        The spring is a function of the commands alone: the plan's own speed (a step's
        sway, an overshoot) never feeds back into the next target. The velocity turns with
        the heading difference between the context and the previous path (after a resync).
        """
        if self.path is None:
            return measured
        k = round((splice_time - self.path_start) * FPS) - 1
        if not 0 <= k < self.path.length:
            return measured
        previous = self.path.state_at(k)
        turn = measured.heading - previous.heading
        c, s = math.cos(turn), math.sin(turn)

        def turned(v: tuple[float, float]) -> tuple[float, float]:
            return (c * v[0] - s * v[1], s * v[0] + c * v[1])

        return RootState(
            position=measured.position, heading=measured.heading, velocity=turned(previous.velocity), yaw_rate=previous.yaw_rate,
            acceleration=turned(previous.acceleration), yaw_acceleration=previous.yaw_acceleration,
        )  # fmt: skip

    def request(self, context: FloatArray, splice_time: float) -> PlanRequest:
        """The plan that continues `context` towards where the spring takes the root under the command."""
        if self.cfg.max_context_tilt_deg is not None:
            context = tilt_limited(context, math.radians(self.cfg.max_context_tilt_deg))
        state = self._continued(root_state_from_frames(context, FPS), splice_time)
        path = root_trajectory(state, self.command, self.cfg.plan_frames, self.cfg.spring, FPS)
        self._previous = (self.path, self.path_start) if self.path is not None else None
        self.path, self.path_start = path, splice_time
        last = self.cfg.plan_frames - 1
        x, y = path.positions[last]
        target = target_root(last, float(x), float(y), float(path.headings[last]))
        first = splice_time + 1.0 / FPS  # plan frame k is at first + k / FPS
        self.gestures = tuple(g for g in self.gestures if g.alive(first, self.cfg.gestures.blend_s))
        arms = self.library.keyframes(self.gestures, first, self.cfg.plan_frames, self.hold_free_arms)
        if arms and arms[-1].frame == last:
            target, arms = merged(target, arms[-1]), arms[:-1]
        self._count += 1  # every plan its own seed: reproducible for a run seed, varied over the run
        keyframes = (*arms, target)
        return PlanRequest(
            context=context,
            keyframes=keyframes,
            lengths=(self.cfg.plan_frames,),
            text_embedding=self.text_embedding,
            seed=self._seed * 100_003 + self._count,
        )


def tilt_limited(frames: FloatArray, max_tilt_rad: float) -> FloatArray:
    """`frames` (qpos [K, 36]) with each root tilt (the rotation left without the heading) at most `max_tilt_rad`, all else kept."""
    out = np.array(frames, dtype=np.float64)
    rotation = out[:, g1.QPOS_ROOT_QUAT]
    yaw = quat.from_yaw(quat.heading(rotation))
    tilt = quat.log(quat.multiply(quat.conjugate(yaw), rotation))  # rotation vectors [K, 3]
    angle = np.linalg.norm(tilt, axis=1, keepdims=True)
    scale = np.minimum(1.0, max_tilt_rad / np.maximum(angle, 1e-12))
    out[:, g1.QPOS_ROOT_QUAT] = quat.multiply(yaw, quat.exp(tilt * scale))
    return out
