"""`g1ctl dataset record` / `import`: motion clips for the planner from the simulated G1 or CSV files.

Recording runs the locomotion policy in MuJoCo under a seeded random command program
(stand, start, stop, walk forward and backward at varied speeds, strafe, turn in place and
while walking, speed changes; segments of 1.5-5 s) while, part of the time, the waist and
arms follow a procedural gesture that overrides the policy's targets for those joints,
blended in and out over 0.5 s with a smoothstep. The state is sampled at 30 fps (policy at
50 Hz, physics at 500 Hz) with foot contacts from physics, the command, the gesture label
and one caption per segment. Episodes last 60-120 s, each with its own seed; after a fall,
the last 2 s before it are dropped and a new episode starts.

Imports MuJoCo (through `sim`).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm import tqdm

from controller.assets import ensure_assets
from controller.inputs.base import CommandLimits, VelocityCommand
from controller.planner.dataset import (
    FPS,
    GESTURES,
    MotionClip,
    csv_files,
    episode_seed,
    import_csv_clips,
    save_dataset,
    split_for_seed,
)
from controller.policies import load_policy
from controller.policy import OnnxPolicy
from hw.errors import ConfigError
from hw.g1 import JOINT_NAMES
from hw.types import FloatArray, JointCommand, RobotState
from sim.recorder import FrameSampler, restart
from sim.robot import SimRobot
from sim.world import build_model

# --- command programs --------------------------------------------------------------------------

SEGMENT_SECONDS = (1.5, 5.0)
COMMAND_RAMP_S = 0.3  # a new command is reached linearly over this time (speed changes: the whole segment)
FORWARD = (0.2, 0.8)  # m/s
BACKWARD = (0.2, 0.6)
STRAFE = (0.15, 0.4)
TURN = (0.3, 0.8)  # rad/s
TURN_WHILE_WALKING = (0.2, 0.6)
SEGMENT_KINDS: dict[str, float] = {  # kind -> weight
    "stand": 0.14,
    "forward": 0.24,
    "backward": 0.10,
    "strafe": 0.10,
    "turn": 0.12,
    "walk_turn": 0.14,
    "diagonal": 0.06,
    "speed_change": 0.10,
}
GESTURE_SHARE = 0.55  # share of segments with a gesture
GESTURE_KEEP = 0.35  # chance a segment keeps the previous segment's gesture


@dataclass(frozen=True)
class Segment:
    """A stretch of an episode: the command goes from `start_cmd` to `cmd` (ramped), one gesture, one caption."""

    start: float  # s from the episode's first frame
    duration: float
    kind: str
    start_cmd: tuple[float, float, float]
    cmd: tuple[float, float, float]  # vx, vy, yaw rate
    ramp: float  # s to reach `cmd`
    gesture: int
    caption: str

    @property
    def end(self) -> float:
        return self.start + self.duration

    def command_at(self, t: float) -> tuple[float, float, float]:
        a = 1.0 if self.ramp <= 0 else min(max((t - self.start) / self.ramp, 0.0), 1.0)
        s, c = self.start_cmd, self.cmd
        return (s[0] + a * (c[0] - s[0]), s[1] + a * (c[1] - s[1]), s[2] + a * (c[2] - s[2]))


def _speed_word(speed: float, slow: float, fast: float) -> str:
    return " slowly" if speed < slow else " quickly" if speed > fast else ""


def _side(value: float) -> str:
    return "left" if value > 0 else "right"


def _draw_command(kind: str, rng: np.random.Generator, prev: tuple[float, float, float]) -> tuple[tuple[float, float, float], str]:
    """The target command of a segment kind and its caption (without the gesture)."""
    moving = any(abs(v) > 1e-6 for v in prev)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    if kind == "stand":
        return (0.0, 0.0, 0.0), "stop and stand still" if moving else "stand still"
    if kind == "forward":
        vx = float(rng.uniform(*FORWARD))
        return (vx, 0.0, 0.0), f"{'walk' if moving else 'start walking'} forward{_speed_word(vx, 0.35, 0.6)}"
    if kind == "backward":
        vx = float(rng.uniform(*BACKWARD))
        return (-vx, 0.0, 0.0), f"{'walk' if moving else 'start walking'} backward{_speed_word(vx, 0.3, 9.0)}"
    if kind == "strafe":
        vy = sign * float(rng.uniform(*STRAFE))
        return (0.0, vy, 0.0), f"step sideways to the {_side(vy)}{_speed_word(abs(vy), 0.25, 9.0)}"
    if kind == "turn":
        yaw = sign * float(rng.uniform(*TURN))
        return (0.0, 0.0, yaw), f"turn {_side(yaw)} in place{_speed_word(abs(yaw), 0.45, 0.65)}"
    if kind == "walk_turn":
        vx = float(rng.uniform(0.25, 0.7))
        yaw = sign * float(rng.uniform(*TURN_WHILE_WALKING))
        return (vx, 0.0, yaw), f"walk forward{_speed_word(vx, 0.35, 0.6)} while turning {_side(yaw)}"
    if kind == "diagonal":
        vx = float(rng.uniform(0.2, 0.5)) * (1.0 if rng.random() < 0.75 else -1.0)
        vy = sign * float(rng.uniform(0.15, 0.3))
        return (vx, vy, 0.0), f"walk {'forward' if vx > 0 else 'backward'} and to the {_side(vy)}"
    if kind == "speed_change":  # only after walking straight forward (see command_program)
        while abs((vx := float(rng.uniform(*FORWARD))) - prev[0]) < 0.25:
            pass
        return (vx, 0.0, 0.0), f"{'speed up' if vx > prev[0] else 'slow down'} while walking forward"
    raise AssertionError(kind)


def command_program(rng: np.random.Generator, duration: float, limits: CommandLimits) -> list[Segment]:
    """Segments covering [0, duration): a standing start, then random kinds with 1.5-5 s each."""
    segments: list[Segment] = []
    kinds = list(SEGMENT_KINDS)
    weights = np.array(list(SEGMENT_KINDS.values()))
    weights /= weights.sum()
    t = 0.0
    prev_cmd = (0.0, 0.0, 0.0)
    prev_gesture = 0
    while t < duration - 1e-9:
        length = float(rng.uniform(*SEGMENT_SECONDS))
        if duration - (t + length) < SEGMENT_SECONDS[0]:  # no stub at the end
            length = duration - t
        kind = "stand" if not segments else str(rng.choice(kinds, p=weights))
        if kind == "speed_change" and not (prev_cmd[0] > 0.15 and prev_cmd[1] == 0.0 and prev_cmd[2] == 0.0):
            kind = "forward"  # a speed change continues a straight forward walk
        cmd, caption = _draw_command(kind, rng, prev_cmd)
        ramp = length if kind == "speed_change" else COMMAND_RAMP_S
        clamped = limits.clamp(VelocityCommand(*cmd))
        cmd = (clamped.vx, clamped.vy, clamped.yaw_rate)
        if prev_gesture and rng.random() < GESTURE_KEEP:
            gesture = prev_gesture
        elif rng.random() < GESTURE_SHARE:
            gesture = int(rng.integers(1, len(GESTURES)))
        else:
            gesture = 0
        segments.append(Segment(t, length, kind, prev_cmd, cmd, ramp, gesture, with_gesture(caption, gesture)))
        prev_cmd, prev_gesture = cmd, gesture
        t += length
    return segments


# --- gestures ------------------------------------------------------------------------------------

UPPER_JOINTS: tuple[str, ...] = JOINT_NAMES[12:]  # waist (3), left arm (7), right arm (7)
BLEND_S = 0.5
_ARM = ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll", "wrist_pitch", "wrist_yaw")
_MIRRORED = {"shoulder_roll", "shoulder_yaw", "wrist_roll", "wrist_yaw", "waist_yaw", "waist_roll"}

GESTURE_PHRASES: dict[str, str] = {
    "wave": "waving the right hand",
    "raise_left": "with the left arm raised",
    "raise_right": "with the right arm raised",
    "raise_both": "with both arms raised",
    "reach": "reaching forward with the right hand",
    "point": "pointing to the front right",
    "arms_crossed": "with arms crossed",
    "hands_on_hips": "with hands on hips",
}


def with_gesture(caption: str, gesture: int) -> str:
    """'walk forward slowly' + wave -> 'walk forward slowly while waving the right hand'."""
    if gesture == 0:
        return caption
    phrase = GESTURE_PHRASES[GESTURES[gesture]]
    if phrase.startswith("with "):
        return f"{caption} {phrase}"
    return f"{caption} and {phrase}" if " while " in caption else f"{caption} while {phrase}"


def _arm(side: str, **angles: float) -> dict[str, float]:
    """Joint targets of one arm given as the left arm's angles; the right arm's are mirrored."""
    sign = -1.0 if side == "right" else 1.0
    out = {}
    for part, value in angles.items():
        if part not in _ARM:
            raise KeyError(part)
        out[f"{side}_{part}_joint"] = sign * value if part in _MIRRORED else value
    return out


# Static poses (rad), chosen with forward kinematics: no self-contact, within the joint
# limits, hands where the names say. Arm gains are low (kp 14), so the arms sag a little
# under gravity; the recorded qpos is what the robot did, not these targets.
_RAISED = {"shoulder_pitch": -2.8, "shoulder_roll": 0.45, "shoulder_yaw": 0.0, "elbow": 1.3, "wrist_roll": 0.0, "wrist_pitch": 0.0}
_WAVE = {"shoulder_pitch": -0.2, "shoulder_roll": 1.3, "shoulder_yaw": 1.4, "elbow": 0.0, "wrist_roll": 0.0, "wrist_pitch": 0.0}
_REACH = {"shoulder_pitch": -1.8, "shoulder_roll": 0.15, "shoulder_yaw": 0.0, "elbow": 1.35, "wrist_roll": 0.0, "wrist_pitch": 0.0}
_POINT = {"shoulder_pitch": -1.75, "shoulder_roll": 0.5, "shoulder_yaw": 0.0, "elbow": 1.5, "wrist_roll": 0.0, "wrist_pitch": 0.0}
_HIPS = {"shoulder_pitch": -0.1, "shoulder_roll": 1.16, "shoulder_yaw": -1.81, "elbow": -0.23, "wrist_roll": 0.0, "wrist_pitch": 0.0}
POSES: dict[str, dict[str, float]] = {
    "wave": _arm("right", **_WAVE),
    "raise_left": _arm("left", **_RAISED),
    "raise_right": _arm("right", **_RAISED),
    "raise_both": {**_arm("left", **_RAISED), **_arm("right", **_RAISED)},
    "reach": _arm("right", **_REACH),
    "point": {**_arm("right", **_POINT), "waist_yaw_joint": -0.15},
    "arms_crossed": {  # left forearm above the right one
        **_arm("left", shoulder_pitch=-0.98, shoulder_roll=-0.16, shoulder_yaw=-1.26, elbow=0.4, wrist_roll=0.0, wrist_pitch=0.0),
        **_arm("right", shoulder_pitch=-0.6, shoulder_roll=-0.17, shoulder_yaw=-1.05, elbow=0.75, wrist_roll=0.0, wrist_pitch=0.0),
    },
    "hands_on_hips": {**_arm("left", **_HIPS), **_arm("right", **_HIPS)},
}
# Periodic parts: joint -> (amplitude rad, frequency Hz).
MOTIONS: dict[str, dict[str, tuple[float, float]]] = {
    "wave": {"right_elbow_joint": (0.4, 1.5)},
    "reach": {"right_shoulder_pitch_joint": (0.12, 0.4), "right_elbow_joint": (0.12, 0.4)},
    "point": {"waist_yaw_joint": (0.08, 0.3)},
}
# Joints that move in a part of the blend only, so that hands clear the thighs and each
# other on the way: joint -> (a, b), the joint's own weight rises from 0 to 1 while the
# gesture's weight goes from a to b (default 0 to 1).
PHASES: dict[str, dict[str, tuple[float, float]]] = {
    "hands_on_hips": {
        **{f"{s}_{part}_joint": (0.0, 0.4) for s in ("left", "right") for part in ("shoulder_roll", "elbow")},
        **{f"{s}_shoulder_yaw_joint": (0.4, 1.0) for s in ("left", "right")},
    },
    "arms_crossed": {f"right_{part}_joint": (0.3, 1.0) for part in _ARM},
}


def smoothstep(x: float) -> float:
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


class GesturePlayer:
    """Upper-body joint targets of each gesture over time, blended with the policy's targets."""

    def __init__(self, joint_names: tuple[str, ...], lower: FloatArray, upper: FloatArray, margin: float = 0.05) -> None:
        self._index = np.array([joint_names.index(j) for j in UPPER_JOINTS])
        lo, hi = lower[self._index] + margin, upper[self._index] - margin
        self._targets: list[FloatArray] = [np.zeros(len(UPPER_JOINTS))]
        self._masks: list[NDArray[np.bool_]] = [np.zeros(len(UPPER_JOINTS), dtype=bool)]
        self._motions: list[list[tuple[int, float, float]]] = [[]]
        self._phases: list[tuple[FloatArray, FloatArray]] = [(np.zeros(len(UPPER_JOINTS)), np.ones(len(UPPER_JOINTS)))]
        for name in GESTURES[1:]:
            pose = POSES[name]
            target = np.zeros(len(UPPER_JOINTS))
            mask = np.zeros(len(UPPER_JOINTS), dtype=bool)
            for joint, value in pose.items():
                k = UPPER_JOINTS.index(joint)
                target[k], mask[k] = value, True
            motions = [(UPPER_JOINTS.index(j), a, f) for j, (a, f) in MOTIONS.get(name, {}).items()]
            for k, amplitude, _ in motions:
                if not lo[k] <= target[k] - amplitude and target[k] + amplitude <= hi[k]:
                    raise ConfigError(f"gesture '{name}' moves {UPPER_JOINTS[k]} past its joint limits")
            outside = mask & ((target < lo) | (target > hi))
            if outside.any():
                raise ConfigError(f"gesture '{name}' puts {[UPPER_JOINTS[k] for k in np.flatnonzero(outside)]} past their joint limits")
            a, b = np.zeros(len(UPPER_JOINTS)), np.ones(len(UPPER_JOINTS))
            for joint, (start, stop) in PHASES.get(name, {}).items():
                a[UPPER_JOINTS.index(joint)], b[UPPER_JOINTS.index(joint)] = start, stop
            self._targets.append(target)
            self._masks.append(mask)
            self._motions.append(motions)
            self._phases.append((a, b))

    @property
    def index(self) -> NDArray[np.int64]:
        """Robot joint indices of `UPPER_JOINTS`."""
        return self._index

    def joint_weights(self, gesture: int, weight: float) -> FloatArray:
        """How far each upper-body joint has moved to the gesture's target (0: policy, 1: gesture) at blend `weight`."""
        a, b = self._phases[gesture]
        return np.where(self._masks[gesture], np.clip((weight - a) / (b - a), 0.0, 1.0), 0.0)

    def apply(self, q: FloatArray, gesture: int, weight: float, tau: float) -> FloatArray:
        """`q` (the policy's targets, robot joint order) with gesture `gesture` blended in at `weight`, `tau` s into it."""
        if gesture == 0 or weight <= 0.0:
            return q
        target = self._targets[gesture].copy()
        for k, amplitude, freq in self._motions[gesture]:
            target[k] += amplitude * math.sin(2.0 * math.pi * freq * tau)
        weights = self.joint_weights(gesture, weight)
        out = q.copy()
        current = out[self._index]
        out[self._index] = current + weights * (target - current)
        return out


def gesture_weight(segments: list[Segment], i: int, t: float) -> float:
    """Blend weight of segment i's gesture at episode time t: smoothstep in after a different gesture, out before one."""
    seg = segments[i]
    w = 1.0
    if i == 0 or segments[i - 1].gesture != seg.gesture:
        w = min(w, smoothstep((t - seg.start) / BLEND_S))
    if i + 1 < len(segments) and segments[i + 1].gesture != seg.gesture:
        w = min(w, smoothstep((seg.end - t) / BLEND_S))
    return w


def gesture_starts(segments: list[Segment]) -> list[float]:
    """For each segment, when its gesture started (earlier when it continues the previous segment's)."""
    starts: list[float] = []
    for i, seg in enumerate(segments):
        starts.append(starts[-1] if i and segments[i - 1].gesture == seg.gesture else seg.start)
    return starts


# --- recording -----------------------------------------------------------------------------------

EPISODE_SECONDS = (60.0, 120.0)
WARMUP_S = 1.0  # standing under the policy after a reset, not recorded
DROP_BEFORE_FALL_S = 2.0
MIN_CLIP_S = 2.0  # shorter remains of a fallen episode are dropped


@dataclass(frozen=True)
class RecordConfig:
    out: Path
    minutes: float
    seed: int = 0
    policy: str = "fastsac"
    progress: bool = False
    assets_dir: str | None = None
    episode_seconds: tuple[float, float] = EPISODE_SECONDS


@dataclass
class Episode:
    clip: MotionClip | None  # None: nothing kept (a fall too early)
    fell: bool
    sim_seconds: float  # simulated, including the warm-up and anything dropped


class Recorder:
    """Runs episodes on one simulated G1 and one policy."""

    def __init__(self, policy: str, assets_dir: str | None) -> None:
        assets = ensure_assets(assets_dir)
        self.robot = SimRobot(build_model(assets.g1_mjcf))
        self.policy: OnnxPolicy = load_policy(policy, assets, self.robot.joint_names)
        if self.policy.joint_names != self.robot.joint_names:
            raise ConfigError(f"policy '{policy}' must drive all {len(JOINT_NAMES)} G1 joints in the standard order to record gestures")
        model = self.robot.model
        ids = [model.joint(j).id for j in self.robot.joint_names]
        self.gestures = GesturePlayer(self.robot.joint_names, model.jnt_range[ids, 0].copy(), model.jnt_range[ids, 1].copy())
        self.sampler = FrameSampler(self.robot, FPS)
        self.limits = self.policy.command_limits
        self.dt = 1.0 / self.policy.cfg.rate_hz

    def episode(self, seed: int, seconds: float, on_tick: Any = None) -> Episode:
        """One episode of `seconds` recorded seconds with its own seed; stops early at a fall."""
        rng = np.random.default_rng(seed)
        robot, policy, sampler = self.robot, self.policy, self.sampler
        restart(robot, yaw=float(rng.uniform(-math.pi, math.pi)))
        policy.reset()
        sim_start = robot.time
        self._run(robot.time + WARMUP_S, lambda _t: (VelocityCommand(), 0, 0.0, 0.0))
        segments = command_program(rng, seconds, self.limits)
        starts = gesture_starts(segments)
        frames = round(seconds * FPS)
        sampler.start()
        t0 = sampler.t0
        cursor = [0]

        def at(now: float) -> tuple[VelocityCommand, int, float, float]:
            t = now - t0
            i = cursor[0]
            while i + 1 < len(segments) and t >= segments[i + 1].start - 1e-9:
                i += 1
            cursor[0] = i
            seg = segments[i]
            vx, vy, yaw = seg.command_at(t)
            return VelocityCommand(vx, vy, yaw), seg.gesture, gesture_weight(segments, i, t), t - starts[i]

        commands = np.zeros((frames, 3))
        labels = np.zeros(frames, dtype=np.int16)
        fell = self._run(t0 + (frames - 0.5) / FPS, at, on_tick, labels=(commands, labels))
        keep = sampler.frames
        if fell:
            keep = max(0, round((robot.time - t0 - DROP_BEFORE_FALL_S) * FPS))
        keep = min(keep, frames, sampler.frames)
        sim_seconds = robot.time - sim_start
        if keep < MIN_CLIP_S * FPS:
            return Episode(None, fell, sim_seconds)
        qpos, contacts = sampler.take(keep)
        captions = tuple((round(s.start * FPS), s.caption) for s in segments if round(s.start * FPS) < keep)
        clip = MotionClip(
            name=f"rec-{seed}",
            qpos=qpos,
            contacts=contacts,
            split=split_for_seed(seed),
            command=commands[:keep],
            gesture=labels[:keep],
            captions=captions,
            source="record",
            seed=seed,
        )
        return Episode(clip, fell, sim_seconds)

    def _hide_gesture(self, state: RobotState, gesture: int, weight: float) -> RobotState:
        """The state as the policy sees it: joints under a gesture read as if they tracked the policy's own targets.

        The locomotion policy never saw raised or crossed arms in training; observing them
        throws its leg actions off (a raised arm felled the robot within 2 s). Hidden, it
        balances the gesture's mass and reaction forces through the base orientation and
        gyro alone, like the decoupled tracker of DESIGN.md.
        """
        w = self.gestures.joint_weights(gesture, weight)
        idx = self.gestures.index
        pos = state.joint_pos.copy()
        vel = state.joint_vel.copy()
        pos[idx] += w * (self.policy.last_target[idx] - pos[idx])
        vel[idx] *= 1.0 - w
        return dataclasses.replace(state, joint_pos=pos, joint_vel=vel)

    def _run(self, until: float, at: Any, on_tick: Any = None, labels: tuple[FloatArray, NDArray[np.int16]] | None = None) -> bool:
        """Policy ticks until time `until` (frames sampled on the way); True when the robot fell."""
        robot, policy, sampler, dt = self.robot, self.policy, self.sampler, self.dt
        while robot.time < until - 1e-9:
            state = robot.read()
            velocity, gesture, weight, tau = at(state.time)
            if gesture and weight > 0.0:
                state = self._hide_gesture(state, gesture, weight)
            command = policy.step(state, velocity)
            if gesture:
                q = self.gestures.apply(command.q, gesture, weight, tau)
                command = JointCommand(q=q, dq=command.dq, kp=command.kp, kd=command.kd, tau_ff=command.tau_ff)
            robot.write(command)
            before = sampler.frames
            sampler.advance_to(state.time + dt)
            if labels is not None and sampler.frames > before:
                commands, gestures = labels
                stop = min(sampler.frames, len(gestures))
                commands[before:stop] = (velocity.vx, velocity.vy, velocity.yaw_rate)
                gestures[before:stop] = gesture
            if on_tick is not None:
                on_tick(dt)
            if robot.has_fallen():
                return True
        return False


def record(cfg: RecordConfig) -> dict[str, Any]:
    """Record `cfg.minutes` of motion into a dataset at `cfg.out`; returns a summary."""
    if not (cfg.minutes > 0 and math.isfinite(cfg.minutes)):
        raise ConfigError(f"--minutes must be positive, got {cfg.minutes}")
    if cfg.seed < 0:
        raise ConfigError(f"--seed must be 0 or more, got {cfg.seed}")
    if cfg.out.exists() and not cfg.out.is_dir():
        raise ConfigError(f"{cfg.out}: exists and is not a folder")
    lo, hi = cfg.episode_seconds
    recorder = Recorder(cfg.policy, cfg.assets_dir)
    target = cfg.minutes * 60.0
    clips: list[MotionClip] = []
    falls = 0
    kept = 0.0
    sim_seconds = 0.0
    wall_start = time.perf_counter()
    with tqdm(total=round(target), unit="s", disable=not cfg.progress, desc="record", file=sys.stderr) as bar:
        pending = [0.0]

        def on_tick(dt: float) -> None:
            pending[0] += dt
            if pending[0] >= 1.0:
                bar.update(1)
                pending[0] -= 1.0

        index = 0
        while target - kept > 0.5 / FPS:
            if index >= 1000:
                raise ConfigError("more than 1000 episodes in one run; record in several runs with different seeds")
            seed = episode_seed(cfg.seed, index)
            rng = np.random.default_rng([seed, 1])
            length = float(rng.uniform(lo, hi))
            remaining = target - kept
            if remaining <= hi:
                length = remaining  # the last episode
            elif remaining - length < lo:
                length = remaining / 2  # no short last episode: two halves within [lo, hi] (when hi >= 2 lo)
            episode = recorder.episode(seed, length, on_tick)
            index += 1
            sim_seconds += episode.sim_seconds
            falls += episode.fell
            if episode.clip is not None:
                clips.append(episode.clip)
                kept += episode.clip.seconds
            bar.n = min(round(kept), round(target))
            bar.refresh()
    wall = time.perf_counter() - wall_start
    extra = {"source": "record", "policy": cfg.policy, "falls": falls, "episodes": index}
    save_dataset(cfg.out, clips, cfg.seed, extra=extra)
    return {
        "out": str(cfg.out),
        "clips": len(clips),
        "episodes": index,
        "falls": falls,
        "minutes": _minutes_per_split(clips),
        "sim_seconds": round(sim_seconds, 2),
        "wall_seconds": round(wall, 2),
        "sim_seconds_per_wall_second": round(sim_seconds / wall, 2) if wall > 0 else None,
    }


def _minutes_per_split(clips: list[MotionClip]) -> dict[str, float]:
    splits = ("train", "val", "test")
    return {s: round(sum(c.seconds for c in clips if c.split == s) / 60.0, 2) for s in splits}


def import_csv(csv: str | Path, out: Path, fps: float = 60.0, assets_dir: str | None = None) -> dict[str, Any]:
    """Import G1 CSV clips (a file or a folder, recursively) at `fps` into a dataset at `out`."""
    from sim.kinematics import G1Kinematics, foot_contacts  # noqa: PLC0415

    root = Path(csv)
    files = csv_files(root)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out}: exists and is not a folder")
    kinematics = G1Kinematics(ensure_assets(assets_dir).g1_mjcf)

    def contacts_of(qpos: FloatArray) -> NDArray[np.bool_]:
        return foot_contacts(kinematics.forward(qpos)[2])

    clips = import_csv_clips(files, root, fps, contacts_of)
    save_dataset(out, clips, None, extra={"source": "csv", "csv_fps": fps})
    return {"out": str(out), "clips": len(clips), "minutes": _minutes_per_split(clips)}
