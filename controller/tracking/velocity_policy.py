"""The velocity tracker: an ONNX locomotion policy, robot state + velocity command -> joint PD command at the policy's rate.

The ONNX file describes itself: joint names, kp and kd (and, where present, the action
scale and command ranges) live in its metadata as JSON values. The YAML config declares
the control rate and the observation layout and may override any metadata value. Every
dimension and joint name is checked when the policy loads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from controller.commands.velocity import CommandLimits, VelocityCommand
from controller.onnx_session import open_session
from controller.reference.window import ReferenceWindow
from controller.tracking.observation import ObservationBuilder, ObservationLayout
from controller.tracking.onnx_policy import ActionFilter, check_io, check_rate, joint_gains, metadata_joint_names, read_metadata
from controller.tracking.tracker import Tracker
from hw import quat
from hw.errors import ConfigError, PolicyError
from hw.g1 import DAMPING_KD, DEFAULT_JOINT_POS
from hw.types import FloatArray, JointCommand, RobotState, read_only

GRAVITY_DIRECTION = np.array([0.0, 0.0, -1.0])  # unit vector, world frame: the policy observes it in the base frame


@dataclass(frozen=True)
class GaitConfig:
    """Two-foot gait clock fed to the policy as sin/cos of each foot's phase."""

    period: float = 1.0
    stand_threshold: float = 0.01  # |command| below this holds both feet at phase pi (standing)


@dataclass(frozen=True)
class PolicyConfig:
    onnx: str  # file name in the asset cache, or a path
    observation: ObservationLayout
    rate_hz: float  # the control rate the policy was trained at: the run loop ticks at it (50 for holosoma's)
    # The pose actions are offsets from; joints not listed are 0 rad. Default: the G1 standing
    # pose the holosoma policies were trained around (hw.g1.DEFAULT_JOINT_POS).
    default_joint_pos: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_JOINT_POS))
    input_name: str = "actor_obs"  # holosoma's exported input and output names
    output_name: str = "action"
    action_scale: float | None = None  # None: from metadata 'action_scale', else an error
    action_clip: float = 100.0
    gait: GaitConfig = field(default_factory=GaitConfig)
    kp: dict[str, float] | None = None  # per-joint overrides of the metadata gains
    kd: dict[str, float] | None = None
    damping_kd: float = DAMPING_KD
    max_consecutive_nonfinite: int = 3  # this many bad outputs in a row latch damping

    def __post_init__(self) -> None:
        if not self.rate_hz > 0:
            raise ValueError(f"rate_hz must be positive, got {self.rate_hz}")


class GaitClock:
    """holosoma's gait phase: feet half a period apart; both at pi while standing."""

    def __init__(self, cfg: GaitConfig, rate_hz: float) -> None:
        self.cfg = cfg
        self.dphase = 2.0 * math.pi / (rate_hz * cfg.period)
        self.reset()

    def reset(self) -> None:
        self.phase = np.array([math.pi, math.pi])
        self.standing = True

    def advance(self, command: VelocityCommand) -> None:
        self.phase = np.fmod(self.phase + self.dphase + math.pi, 2 * math.pi) - math.pi
        lin = math.hypot(command.vx, command.vy)
        if lin < self.cfg.stand_threshold and abs(command.yaw_rate) < self.cfg.stand_threshold:
            self.phase[:] = math.pi
            self.standing = True
        elif self.standing:
            self.phase = np.array([0.0, math.pi])
            self.standing = False


class VelocityPolicy(Tracker):
    """The velocity-command locomotion policy as a tracker: follows the reference window's base velocity."""

    name = "velocity"

    def __init__(self, path: Path, cfg: PolicyConfig, robot_joint_names: tuple[str, ...], source: str = "policy config") -> None:
        self.cfg = cfg
        self.path = path
        self.rate_hz = cfg.rate_hz
        if not path.is_file():
            raise PolicyError(f"policy file not found: {path}; run 'g1ctl assets fetch' or pass a valid path")
        self._session = open_session(path, PolicyError, "ONNX policy")
        meta = read_metadata(self._session)
        self.joint_names = metadata_joint_names(meta, path)
        n = len(self.joint_names)
        cfg.observation.check(n, source)
        check_io(self._session, path, cfg.input_name, cfg.output_name, cfg.observation.size, n)
        check_rate(meta, cfg.rate_hz, path, source)
        missing = [j for j in self.joint_names if j not in robot_joint_names]
        if missing:
            raise PolicyError(f"{path.name}: joints {missing} are not on the robot (robot joints: {len(robot_joint_names)})")
        unknown = [j for j in cfg.default_joint_pos if j not in self.joint_names]
        if unknown:
            raise ConfigError(f"{source}: default_joint_pos names unknown joints {unknown}")
        # Robot array index of each policy joint (a plain slice when the orders agree).
        order = [robot_joint_names.index(j) for j in self.joint_names]
        self.robot_index: slice | np.ndarray = slice(None) if order == list(range(len(robot_joint_names))) else np.array(order)
        # Arrays every command shares are read-only: a joint command never copies them.
        self.kp = read_only(joint_gains("kp", meta, cfg.kp, self.joint_names, path, source))
        self.kd = read_only(joint_gains("kd", meta, cfg.kd, self.joint_names, path, source))
        self.default_pos = read_only(np.array([cfg.default_joint_pos.get(j, 0.0) for j in self.joint_names]))
        scale = cfg.action_scale if cfg.action_scale is not None else meta.get("action_scale")
        if scale is None:
            raise PolicyError(f"{path.name}: no action scale in metadata; set 'action_scale' in {source}")
        self.action_scale = np.broadcast_to(np.asarray(scale, float), (n,)).copy()
        self.command_limits = _command_limits(meta)
        self.obs = ObservationBuilder(cfg.observation)
        self.gait = GaitClock(cfg.gait, cfg.rate_hz)
        self._slot = {t.name: self.obs.slot(t.name) for t in cfg.observation.terms}
        self._zeros = read_only(np.zeros(n))
        self._damp_kd = read_only(np.full(n, cfg.damping_kd))
        self.actions = ActionFilter(self.action_scale, self.default_pos, cfg.action_clip, cfg.max_consecutive_nonfinite)
        self.reset()

    @property
    def latched_fault(self) -> str | None:
        return self.actions.latched_fault

    @property
    def nonfinite_events(self) -> int:
        return self.actions.nonfinite_events

    @property
    def last_action(self) -> FloatArray:
        return self.actions.last_action

    @property
    def last_target(self) -> FloatArray:
        """The last safe joint target (held through a non-finite output, and while damping)."""
        return self.actions.last_target

    def reset(self) -> None:
        self.obs.reset()
        self.gait.reset()
        self.actions.reset()

    def observe(self, state: RobotState, command: VelocityCommand) -> np.ndarray:
        """Assemble the policy input for this tick (raw values into their slots, then one scaling)."""
        raw, slot, idx = self.obs.raw, self._slot, self.robot_index
        raw[slot["dof_pos"]] = state.joint_pos[idx]
        raw[slot["dof_pos"]] -= self.default_pos
        raw[slot["dof_vel"]] = state.joint_vel[idx]
        raw[slot["actions"]] = self.last_action
        if "base_ang_vel" in slot:
            raw[slot["base_ang_vel"]] = state.base_ang_vel
        if "projected_gravity" in slot:
            raw[slot["projected_gravity"]] = quat.rotate_inverse_one(state.base_quat, GRAVITY_DIRECTION)
        if "base_lin_vel" in slot:
            raw[slot["base_lin_vel"]] = quat.rotate_inverse_one(state.base_quat, state.base_lin_vel)
        if "command_lin_vel" in slot:
            raw[slot["command_lin_vel"]] = (command.vx, command.vy)
        if "command_ang_vel" in slot:
            raw[slot["command_ang_vel"]] = command.yaw_rate
        if "sin_phase" in slot or "cos_phase" in slot:
            p0, p1 = self.gait.phase.tolist()
            if "sin_phase" in slot:
                raw[slot["sin_phase"]] = (math.sin(p0), math.sin(p1))
            if "cos_phase" in slot:
                raw[slot["cos_phase"]] = (math.cos(p0), math.cos(p1))
        return self.obs.commit()

    def infer(self, obs: np.ndarray) -> FloatArray:
        out = self._session.run([self.cfg.output_name], {self.cfg.input_name: obs})[0]
        return np.asarray(out, float).reshape(-1)

    def step(self, state: RobotState, reference: ReferenceWindow) -> JointCommand:
        """One control tick. A non-finite output holds the last safe target; repeated ones latch damping."""
        if self.latched_fault is not None:
            return self.damping_command()
        command = reference.velocity
        target = self.actions.target(self.infer(self.observe(state, command)))
        if target is None:
            return self.damping_command()
        self.gait.advance(command)
        return JointCommand(q=target, dq=self._zeros, kp=self.kp, kd=self.kd, tau_ff=self._zeros)

    def damping_command(self) -> JointCommand:
        return JointCommand(q=self.last_target, dq=self._zeros, kp=self._zeros, kd=self._damp_kd, tau_ff=self._zeros)


def _command_limits(meta: dict[str, object]) -> CommandLimits:
    ranges = meta.get("command_ranges")
    if not isinstance(ranges, dict):
        return CommandLimits()

    def pair(key: str) -> tuple[float, float]:
        lo, hi = ranges.get(key, (-1.0, 1.0))
        return float(lo), float(hi)

    return CommandLimits(vx=pair("lin_vel_x"), vy=pair("lin_vel_y"), yaw_rate=pair("ang_vel_yaw"))
