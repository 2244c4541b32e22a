"""`g1ctl dataset record`: motion clips for the planner from the simulated G1.

Recording runs the locomotion policy in MuJoCo under a seeded random command program
(stand, start, stop, walk forward and backward at varied speeds, strafe, turn in place and
while walking, speed changes; segments of 1.5-5 s) while, part of the time, the waist and
arms follow a procedural gesture that overrides the policy's targets for those joints,
blended in and out over 0.5 s with a smoothstep. The state is sampled at 30 fps (policy at
50 Hz, physics at 500 Hz) with foot contacts from physics, the command, the gesture label
and one caption per segment. Episodes last 60-120 s, each with its own seed; after a fall,
the last 2 s before it are dropped and a new episode starts.

An application above the dataset it writes (`motion_data`): like the evaluation suites it
drives whole runs as seeded tasks on `executor`, so it sits beside them. Imports MuJoCo (through `sim`).
"""

from __future__ import annotations

import atexit
import dataclasses
import functools
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
from controller.commands.gestures import GesturePlayer
from controller.commands.velocity import VelocityCommand
from controller.eval.executor import Executor, TaskLost
from controller.motion_data.command_programs import command_program, gesture_starts, gesture_weight
from controller.motion_data.dataset import FPS, MotionClip, episode_seed, minutes_per_split, save_dataset, split_for_seed
from controller.reference.window import ReferenceWindow
from controller.tracking.presets import load_policy
from controller.tracking.velocity_policy import VelocityPolicy
from hw.errors import ConfigError
from hw.g1 import JOINT_NAMES
from hw.types import FloatArray, JointCommand, RobotState
from sim.recorder import FrameSampler, restart
from sim.robot import SimRobot
from sim.world import build_model

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
    workers: int = 1  # episodes at a time; more than 1 (or an address) runs them as Ray tasks
    address: str | None = None  # an existing Ray cluster


@dataclass
class RecordedEpisode:
    """What one recording episode gave: its clip, whether the robot fell, the simulated time spent."""

    clip: MotionClip | None  # None: nothing kept (a fall too early)
    fell: bool
    sim_seconds: float  # simulated, including the warm-up and anything dropped


class Recorder:
    """Runs episodes on one simulated G1 and one policy."""

    def __init__(self, policy: str, assets_dir: str | None) -> None:
        assets = ensure_assets(assets_dir)
        self.robot = SimRobot(build_model(assets.g1_mjcf))
        self.policy: VelocityPolicy = load_policy(policy, assets, self.robot.joint_names)
        if self.policy.joint_names != self.robot.joint_names:
            raise ConfigError(f"policy '{policy}' must drive all {len(JOINT_NAMES)} G1 joints in the standard order to record gestures")
        model = self.robot.model
        ids = [model.joint(j).id for j in self.robot.joint_names]
        self.gestures = GesturePlayer(self.robot.joint_names, model.jnt_range[ids, 0].copy(), model.jnt_range[ids, 1].copy())
        self.sampler = FrameSampler(self.robot, FPS)
        self.limits = self.policy.command_limits
        self.dt = 1.0 / self.policy.cfg.rate_hz

    def close(self) -> None:
        """Closes the simulated G1; safe twice."""
        self.robot.close()

    def episode(self, seed: int, seconds: float) -> RecordedEpisode:
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
        fell = self._run(t0 + (frames - 0.5) / FPS, at, labels=(commands, labels))
        keep = sampler.frames
        if fell:
            keep = max(0, round((robot.time - t0 - DROP_BEFORE_FALL_S) * FPS))
        keep = min(keep, frames, sampler.frames)
        sim_seconds = robot.time - sim_start
        if keep < MIN_CLIP_S * FPS:
            return RecordedEpisode(None, fell, sim_seconds)
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
        return RecordedEpisode(clip, fell, sim_seconds)

    def _hide_gesture(self, state: RobotState, gesture: int, weight: float) -> RobotState:
        """The state as the policy sees it: joints under a gesture read as if they tracked the policy's own targets.

        The locomotion policy never saw raised or crossed arms in training; observing them
        throws its leg actions off (a raised arm felled the robot within 2 s). Hidden, it
        balances the gesture's mass and reaction forces through the base orientation and
        gyro alone, like the decoupled tracker.
        """
        w = self.gestures.joint_weights(gesture, weight)
        idx = self.gestures.index
        pos = state.joint_pos.copy()
        vel = state.joint_vel.copy()
        pos[idx] += w * (self.policy.last_target[idx] - pos[idx])
        vel[idx] *= 1.0 - w
        return dataclasses.replace(state, joint_pos=pos, joint_vel=vel)

    def _run(self, until: float, at: Any, labels: tuple[FloatArray, NDArray[np.int16]] | None = None) -> bool:
        """Policy ticks until time `until` (frames sampled on the way); True when the robot fell."""
        robot, policy, sampler, dt = self.robot, self.policy, self.sampler, self.dt
        while robot.time < until - 1e-9:
            state = robot.read()
            velocity, gesture, weight, tau = at(state.time)
            if gesture and weight > 0.0:
                state = self._hide_gesture(state, gesture, weight)
            command = policy.step(state, ReferenceWindow(state.time, velocity))
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
            if robot.has_fallen():
                return True
        return False


def record(cfg: RecordConfig) -> dict[str, Any]:
    """Record `cfg.minutes` of motion into a dataset at `cfg.out`; returns a summary.

    Episodes run `cfg.workers` at a time (Ray; in this process with one worker). Each episode's
    seed and length are what one worker alone would choose: a wave of episodes is planned
    ahead, and an episode whose length an earlier one's fall changed is dropped and planned
    again, so the clips are the same whatever the number of workers.
    """
    if not (cfg.minutes > 0 and math.isfinite(cfg.minutes)):
        raise ConfigError(f"--minutes must be positive, got {cfg.minutes}")
    if cfg.seed < 0:
        raise ConfigError(f"--seed must be 0 or more, got {cfg.seed}")
    if cfg.out.exists() and not cfg.out.is_dir():
        raise ConfigError(f"{cfg.out}: exists and is not a folder")
    target = cfg.minutes * 60.0
    clips: list[MotionClip] = []
    falls = index = 0
    kept = sim_seconds = 0.0
    wall_start = time.perf_counter()
    with (
        Executor(cfg.workers, cfg.address) as executor,
        tqdm(total=round(target), unit="s", disable=not cfg.progress, desc="record", file=sys.stderr) as bar,
    ):
        while target - kept > 0.5 / FPS:
            if index >= 1000:
                raise ConfigError("more than 1000 episodes in one run; record in several runs with different seeds")
            wave = _plan(cfg, index, kept, target, count=1 if executor.in_process else 2 * cfg.workers)
            results: dict[int, RecordedEpisode] = {}
            for i, episode in executor.map_unordered(_record_episode, [(cfg.policy, cfg.assets_dir, seed, n) for seed, n in wave]):
                if isinstance(episode, TaskLost):
                    raise ConfigError(f"recording episode {index + i} was lost twice ({episode}); run again")
                results[i] = episode
            for i, planned in enumerate(wave):
                if planned != _episode_plan(cfg, index, kept, target):
                    break  # an earlier fall changed what comes next: plan again from here
                episode = results[i]
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
        "workers": cfg.workers,
        "minutes": minutes_per_split(clips),
        "sim_seconds": round(sim_seconds, 2),
        "wall_seconds": round(wall, 2),
        "sim_seconds_per_wall_second": round(sim_seconds / wall, 2) if wall > 0 else None,
    }


def _episode_plan(cfg: RecordConfig, index: int, kept: float, target: float) -> tuple[int, float]:
    """The seed and length of episode `index` once `kept` seconds are kept (what a sequential recording does)."""
    lo, hi = cfg.episode_seconds
    seed = episode_seed(cfg.seed, index)
    length = float(np.random.default_rng([seed, 1]).uniform(lo, hi))
    remaining = target - kept
    if remaining <= hi:
        length = remaining  # the last episode
    elif remaining - length < lo:
        length = remaining / 2  # no short last episode: two halves within [lo, hi] (when hi >= 2 lo)
    return seed, length


def _plan(cfg: RecordConfig, index: int, kept: float, target: float, count: int) -> list[tuple[int, float]]:
    """Up to `count` episodes ahead, assuming none falls (each keeps its whole length)."""
    wave: list[tuple[int, float]] = []
    while len(wave) < count and target - kept > 0.5 / FPS and index + len(wave) < 1000:
        seed, length = _episode_plan(cfg, index + len(wave), kept, target)
        wave.append((seed, length))
        kept += length
    return wave


@functools.cache
def _recorder(policy: str, assets_dir: str | None) -> Recorder:
    """One recorder per process (and per Ray worker): the policy and the model load once, the robot
    closes when the process exits."""
    recorder = Recorder(policy, assets_dir)
    atexit.register(recorder.close)
    return recorder


def _record_episode(policy: str, assets_dir: str | None, seed: int, length: float) -> RecordedEpisode:
    return _recorder(policy, assets_dir).episode(seed, length)
