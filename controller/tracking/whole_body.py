"""The whole-body tracker: holosoma's whole-body tracking ONNX policy, fed the planned motion.

The policy (holosoma-inference 0.1.3, `models/wbt/*_g1_29dof_dancing.onnx`, trained with
BeyondMimic's observation contract) tracks a reference pose: each tick (its YAML's rate_hz) it sees the
reference's joint positions and velocities, the reference torso's rotation in the robot
torso's frame, the pelvis gyro, the joint state relative to the default pose and its last
action, and returns joint offsets around the default pose. Here the reference is the plan
sampled now (`ReferenceWindow.plan`) instead of the dance clip the export carries.

Conventions, as holosoma-inference's runner (`policies/wbt.py`, `policies/base.py`) and
configs (`config_values/observation.py` 'wbt', `task.py` 'wbt', `robot.py`) apply them:
- the observation terms are concatenated in alphabetical order of their names (the YAML
  lists them so), with scale 1 and no history;
- `motion_command` is the reference's absolute joint positions then joint velocities, in the
  policy's joint order;
- `motion_ref_ori_b` is the reference torso_link rotation expressed in the robot's torso_link
  frame, as the first two columns of its rotation matrix, row-major (r00 r01 r10 r11 r20 r21);
  both torsos have the yaw they had when the policy started removed, so the reference is
  aligned to the robot's heading at the start (and again after every `reset`);
- `base_ang_vel` is the pelvis gyro, `dof_pos` is joint position minus the default pose;
- target = default pose + action * scale, actions clipped to +-100 first. Neither export has
  `action_scale` metadata; holosoma's runner then applies 0.25 * effort limit / kp per joint
  (BeyondMimic's; `G1_29DOF_PER_JOINT_ACTION_SCALE`). That is right for the ppo export (its
  training config says so) but not for the fastsac one, which acts in radians (scale 1): the
  presets (configs/policies/wbt_*.yaml) say which and how it was established;
- kp and kd come from the ONNX metadata (the gains the policy was trained with).

Where this runner differs on purpose: holosoma feeds the clip frame its previous call
returned (one tick behind the frame index it passes); here the observation holds the plan at
this tick's time, which is what the policy saw in training (the command of step t is the
motion at t). The export's `time_step` input only indexes its embedded clip; it is fed 0 and
the clip outputs are never read.

Without a plan (no `--planner`) a step raises `ConfigError`: the only reference then is a
velocity command, which this policy cannot follow, and holding a stand instead would ignore
the user's commands without a word. Limits: both exports were trained on one dance clip and
see no reference root position or velocity (holosoma's `motion_ref_pos_b` is a critic term),
so nothing pulls the robot back onto the planned path; poses far from the clip are tracked
with the clip's bias (fastsac holds its elbows nearly straight whatever the reference says).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from controller.assets import Assets
from controller.commands.velocity import CommandLimits
from controller.onnx_session import open_session
from controller.reference.window import ReferenceWindow
from controller.tracking.observation import ObservationBuilder, ObservationLayout
from controller.tracking.onnx_policy import ActionFilter, check_io, check_rate, joint_gains, metadata_joint_names, read_metadata
from controller.tracking.presets import available_policies, onnx_file, policy_config_path
from controller.tracking.tracker import Tracker
from hw import g1
from hw.errors import ConfigError, PolicyError
from hw.g1 import DAMPING_KD, DEFAULT_JOINT_POS, EFFORT_LIMITS
from hw.types import FloatArray, JointCommand, RobotState, read_only
from hw.yamlconfig import load_config

# The terms this tracker computes (a layout naming any other is refused when it loads).
WHOLE_BODY_TERMS = frozenset({"actions", "base_ang_vel", "dof_pos", "dof_vel", "motion_command", "motion_ref_ori_b"})

# Presets of this tracker are the policy presets named with this prefix (configs/policies/wbt_*.yaml).
PRESET_PREFIX = "wbt_"

Quat = tuple[float, float, float, float]


@dataclass(frozen=True)
class WholeBodyConfig:
    onnx: str  # file name in the asset cache, or a path
    observation: ObservationLayout
    rate_hz: float  # the control rate the policy was trained at: the run loop ticks at it (50 for holosoma's)
    # The pose actions are offsets from (and `dof_pos` is relative to); joints not listed are 0 rad.
    default_joint_pos: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_JOINT_POS))
    input_name: str = "obs"  # holosoma's whole-body export: input 'obs', output 'actions'
    output_name: str = "actions"
    clip_input: str | None = "time_step"  # the export's index into its own clip: fed 0, its outputs unused
    action_scale: float | None = None  # one scale for all joints; None: metadata 'action_scale', else effort_action_scale
    # scale_j = effort_action_scale * effort_limit_j / kp_j, kp from the metadata (the gains the policy was
    # trained with, whatever `kp` overrides say): BeyondMimic's per-joint action scale.
    effort_action_scale: float | None = None
    action_clip: float = 100.0
    kp: dict[str, float] | None = None  # per-joint overrides of the metadata gains
    kd: dict[str, float] | None = None
    damping_kd: float = DAMPING_KD
    max_consecutive_nonfinite: int = 3  # this many bad outputs in a row latch damping
    anchor_body: str = g1.TORSO_BODY  # the body whose orientation is tracked; torso_link: the waist chain is computed here

    def __post_init__(self) -> None:
        if not self.rate_hz > 0:
            raise ValueError(f"rate_hz must be positive, got {self.rate_hz}")
        if self.anchor_body != g1.TORSO_BODY:
            raise ValueError(f"anchor_body must be '{g1.TORSO_BODY}' (the only anchor this tracker computes), got '{self.anchor_body}'")


class WholeBodyTracker(Tracker):
    """Tracks the planned whole-body motion with a BeyondMimic-style policy; needs the planner in the loop."""

    name = "whole-body"
    needs_plan = True

    def __init__(self, path: Path, cfg: WholeBodyConfig, robot_joint_names: tuple[str, ...], source: str = "policy config") -> None:
        self.cfg = cfg
        self.path = path
        self.rate_hz = cfg.rate_hz
        self.command_limits = CommandLimits()  # commands go to the planner, not to the policy
        if not path.is_file():
            raise PolicyError(f"policy file not found: {path}; run 'g1ctl assets fetch' or pass a valid path")
        self._session = open_session(path, PolicyError, "ONNX policy")
        meta = read_metadata(self._session)
        self.joint_names = metadata_joint_names(meta, path)
        n = len(self.joint_names)
        cfg.observation.check(n, source, WHOLE_BODY_TERMS)
        self._feed = self._check_io(cfg, n)
        check_rate(meta, cfg.rate_hz, path, source)
        for joints, where in ((robot_joint_names, "on the robot"), (g1.JOINT_NAMES, "in the planned reference (the G1's joints)")):
            missing = [j for j in self.joint_names if j not in joints]
            if missing:
                raise PolicyError(f"{path.name}: joints {missing} are not {where}")
        unknown = [j for j in cfg.default_joint_pos if j not in self.joint_names]
        if unknown:
            raise ConfigError(f"{source}: default_joint_pos names unknown joints {unknown}")
        order = [robot_joint_names.index(j) for j in self.joint_names]
        self.robot_index: slice | np.ndarray = slice(None) if order == list(range(len(robot_joint_names))) else np.array(order)
        # Reference joints (qpos order, g1.JOINT_NAMES) in the policy's order.
        self.reference_index = np.array([g1.JOINT_NAMES.index(j) for j in self.joint_names])
        waist = ("waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint")
        absent = [j for j in waist if j not in robot_joint_names]
        if absent:
            raise PolicyError(f"the robot has no {absent}: the torso's orientation cannot be computed")
        self._robot_waist = [robot_joint_names.index(j) for j in waist]
        self._reference_waist = [g1.QPOS_JOINTS.start + g1.JOINT_NAMES.index(j) for j in waist]
        metadata_kp = joint_gains("kp", meta, None, self.joint_names, path, source)
        self.kp = read_only(joint_gains("kp", meta, cfg.kp, self.joint_names, path, source))
        self.kd = read_only(joint_gains("kd", meta, cfg.kd, self.joint_names, path, source))
        self.default_pos = read_only(np.array([cfg.default_joint_pos.get(j, 0.0) for j in self.joint_names]))
        self.action_scale = read_only(self._action_scale(meta, metadata_kp, source))
        self.obs = ObservationBuilder(cfg.observation)
        self._slot = {t.name: self.obs.slot(t.name) for t in cfg.observation.terms}
        self._zeros = read_only(np.zeros(n))
        self._damp_kd = read_only(np.full(n, cfg.damping_kd))
        self.actions = ActionFilter(self.action_scale, self.default_pos, cfg.action_clip, cfg.max_consecutive_nonfinite)
        self.reset()

    # -- loading -------------------------------------------------------------------------

    def _check_io(self, cfg: WholeBodyConfig, n: int) -> dict[str, np.ndarray]:
        """Check the ONNX inputs and outputs against the config; return the input feed, the observation slot left empty."""
        inputs = check_io(self._session, self.path, cfg.input_name, cfg.output_name, cfg.observation.size, n)
        name = self.path.name
        if cfg.clip_input is not None and cfg.clip_input not in inputs:
            raise PolicyError(
                f"{name}: no input '{cfg.clip_input}' (inputs: {', '.join(inputs)}); fix or clear 'clip_input' in the policy config"
            )
        unfed = [i for i in inputs if i not in (cfg.input_name, cfg.clip_input)]
        if unfed:
            raise PolicyError(f"{name}: inputs {unfed} are not fed by this tracker (it feeds 'input_name' and 'clip_input')")
        return {cfg.clip_input: np.zeros((1, 1), dtype=np.float32)} if cfg.clip_input is not None else {}

    def _action_scale(self, meta: dict[str, object], kp: FloatArray, source: str) -> FloatArray:
        """The config's scale, else the metadata's (a number, a list or holosoma's comma-separated text), else effort / kp."""
        n = len(self.joint_names)
        if self.cfg.action_scale is not None:
            return np.full(n, self.cfg.action_scale)
        raw = meta.get("action_scale")
        if raw is not None:
            values = np.array([float(v) for v in raw.split(",") if v.strip()] if isinstance(raw, str) else raw, dtype=float).reshape(-1)
            if values.size not in (1, n):
                raise PolicyError(f"{self.path.name}: metadata 'action_scale' has {values.size} values for {n} joints")
            return np.broadcast_to(values, (n,)).copy()
        if self.cfg.effort_action_scale is not None:
            unknown = [j for j in self.joint_names if j not in EFFORT_LIMITS]
            if unknown:
                raise PolicyError(f"{self.path.name}: no effort limit for joints {unknown}; set 'action_scale' in {source}")
            effort = np.array([EFFORT_LIMITS[j] for j in self.joint_names])
            return self.cfg.effort_action_scale * effort / kp
        raise PolicyError(f"{self.path.name}: no action scale in metadata; set 'action_scale' or 'effort_action_scale' in {source}")

    # -- running -------------------------------------------------------------------------

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
        return self.actions.last_target

    def reset(self) -> None:
        self.obs.reset()
        self.actions.reset()
        self._yaw_offset: Quat | None = None  # captured at the first step: robot torso yaw minus reference torso yaw

    def observe(self, state: RobotState, reference: ReferenceWindow) -> np.ndarray:
        """Assemble the policy input for this tick (raw values into their slots, then one scaling)."""
        plan = reference.plan
        if plan is None:
            raise ConfigError(
                "the whole-body tracker follows planned whole-body motion and got no plan: run it with --planner "
                "(a velocity command alone is for the 'velocity' and 'decoupled' trackers)"
            )
        raw, slot, idx = self.obs.raw, self._slot, self.robot_index
        if "motion_command" in slot:
            n = len(self.joint_names)
            cols = slot["motion_command"]
            raw[cols.start : cols.start + n] = plan.qpos[g1.QPOS_JOINTS][self.reference_index]
            raw[cols.start + n : cols.stop] = plan.joint_velocity[self.reference_index]
        if "motion_ref_ori_b" in slot:
            raw[slot["motion_ref_ori_b"]] = self._reference_orientation(state, plan.qpos)
        if "base_ang_vel" in slot:
            raw[slot["base_ang_vel"]] = state.base_ang_vel
        if "dof_pos" in slot:
            raw[slot["dof_pos"]] = state.joint_pos[idx]
            raw[slot["dof_pos"]] -= self.default_pos
        if "dof_vel" in slot:
            raw[slot["dof_vel"]] = state.joint_vel[idx]
        if "actions" in slot:
            raw[slot["actions"]] = self.last_action
        return self.obs.commit()

    def _reference_orientation(self, state: RobotState, qpos: FloatArray) -> tuple[float, ...]:
        """The reference torso's rotation in the robot torso's frame, yaw-aligned at the start: 6 matrix entries."""
        robot = torso_quat(state.base_quat, state.joint_pos[self._robot_waist])
        ref = torso_quat(qpos[g1.QPOS_ROOT_QUAT], qpos[self._reference_waist])
        if self._yaw_offset is None:
            # holosoma removes each torso's yaw at the start: rot_z(-yaw_robot0) r_robot and rot_z(-yaw_ref0) r_ref;
            # in the relative rotation that is one rot_z(yaw_robot0 - yaw_ref0) applied to the reference.
            turn = 0.5 * (_yaw(robot) - _yaw(ref))
            self._yaw_offset = (math.cos(turn), 0.0, 0.0, math.sin(turn))
        w, x, y, z = _mul(_conj(robot), _mul(self._yaw_offset, ref))
        return (
            1 - 2 * (y * y + z * z),
            2 * (x * y - w * z),
            2 * (x * y + w * z),
            1 - 2 * (x * x + z * z),
            2 * (x * z - w * y),
            2 * (y * z + w * x),
        )

    def infer(self, obs: np.ndarray) -> FloatArray:
        self._feed[self.cfg.input_name] = obs
        out = self._session.run([self.cfg.output_name], self._feed)[0]
        return np.asarray(out, float).reshape(-1)

    def step(self, state: RobotState, reference: ReferenceWindow) -> JointCommand:
        """One control tick. A non-finite output holds the last safe target; repeated ones latch damping."""
        if self.latched_fault is not None:
            return self.damping_command()
        target = self.actions.target(self.infer(self.observe(state, reference)))
        if target is None:
            return self.damping_command()
        return JointCommand(q=target, dq=self._zeros, kp=self.kp, kd=self.kd, tau_ff=self._zeros)

    def damping_command(self) -> JointCommand:
        return JointCommand(q=self.last_target, dq=self._zeros, kp=self._zeros, kd=self._damp_kd, tau_ff=self._zeros)


def torso_quat(pelvis_quat: FloatArray, waist: FloatArray) -> Quat:
    """torso_link's world orientation (w, x, y, z) from the pelvis's and the waist angles (yaw, roll, pitch).

    The G1 waist chain (holosoma's g1_29dof MJCF and the URDF in the policy's metadata): pelvis ->
    waist_yaw_joint (z) -> waist_roll_joint (x) -> waist_pitch_joint (y) -> torso_link, every
    joint frame unrotated.
    """
    yaw, roll, pitch = (0.5 * float(a) for a in waist)
    w, x, y, z = (float(v) for v in pelvis_quat)
    q = _mul((w, x, y, z), (math.cos(yaw), 0.0, 0.0, math.sin(yaw)))
    q = _mul(q, (math.cos(roll), math.sin(roll), 0.0, 0.0))
    return _mul(q, (math.cos(pitch), 0.0, math.sin(pitch), 0.0))


def _mul(a: Quat, b: Quat) -> Quat:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def _conj(q: Quat) -> Quat:
    return (q[0], -q[1], -q[2], -q[3])


def _yaw(q: Quat) -> float:
    w, x, y, z = q
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


# -- presets ---------------------------------------------------------------------------------


def whole_body_preset(policy: str) -> str:
    """The whole-body preset for `--policy`: a `wbt_*` preset or a YAML path as given; a locomotion preset name
    (the default 'fastsac', or 'ppo') picks the whole-body policy trained the same way ('wbt_fastsac', 'wbt_ppo')."""
    if policy.startswith(PRESET_PREFIX) or Path(policy).suffix in (".yaml", ".yml"):
        return policy
    presets = [p for p in available_policies() if p.startswith(PRESET_PREFIX)]
    if PRESET_PREFIX + policy in presets:
        return PRESET_PREFIX + policy
    raise ConfigError(f"policy '{policy}' has no whole-body counterpart; the whole-body presets are: {', '.join(presets)}")


def load_whole_body(name_or_path: str, assets: Assets, robot_joint_names: tuple[str, ...]) -> WholeBodyTracker:
    """Load a whole-body preset (name or YAML path) and its ONNX file, checked against the robot's joints."""
    cfg_path = policy_config_path(name_or_path)
    cfg = load_config(WholeBodyConfig, cfg_path)
    return WholeBodyTracker(onnx_file(cfg.onnx, cfg_path, assets), cfg, robot_joint_names, source=str(cfg_path))
