"""Safety layer between the controller and the motors: pure checks on commands and feedback.

Commands are clamped to the joint map (position, velocity, torque) and a position target
may move at most `max_position_step` per cycle. Feedback faults: a stale motor (no reply
within `reply_timeout`), too many missed replies, a motor error code, over-temperature,
a bus fault, a stale IMU, a non-finite target. Any fault latches damping on all joints.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from hw.dds.config import DdsJointConfig
from hw.jointmap import JointConfig, SafetyConfig
from hw.types import FloatArray, JointCommand


@dataclass(frozen=True)
class JointLimits:
    """Joint-side limits as arrays in robot joint order."""

    q_min: FloatArray
    q_max: FloatArray
    dq_max: FloatArray
    tau_max: FloatArray

    @staticmethod
    def from_joint_map(names: tuple[str, ...], joints: Mapping[str, JointConfig | DdsJointConfig]) -> JointLimits:
        return JointLimits(
            q_min=np.array([joints[n].position_limits[0] for n in names]),
            q_max=np.array([joints[n].position_limits[1] for n in names]),
            dq_max=np.array([joints[n].velocity_limit for n in names]),
            tau_max=np.array([joints[n].torque_limit for n in names]),
        )


def limit_command(cmd: JointCommand, limits: JointLimits, previous_q: FloatArray | None, max_step: float) -> tuple[JointCommand, int]:
    """Clamp a finite command to the limits and the per-cycle step; returns it and how many values were changed."""
    lo, hi = limits.q_min, limits.q_max
    if previous_q is not None:
        lo, hi = np.maximum(lo, previous_q - max_step), np.minimum(hi, previous_q + max_step)
    q = np.minimum(np.maximum(cmd.q, lo), hi)
    dq = np.minimum(np.maximum(cmd.dq, -limits.dq_max), limits.dq_max)
    tau = np.minimum(np.maximum(cmd.tau_ff, -limits.tau_max), limits.tau_max)
    kp, kd = np.maximum(cmd.kp, 0.0), np.maximum(cmd.kd, 0.0)
    changed = int(np.count_nonzero(q != cmd.q) + np.count_nonzero(dq != cmd.dq) + np.count_nonzero(tau != cmd.tau_ff))
    changed += int(np.count_nonzero(kp != cmd.kp) + np.count_nonzero(kd != cmd.kd))
    return JointCommand(q=q, dq=dq, kp=kp, kd=kd, tau_ff=tau), changed


def command_is_finite(cmd: JointCommand) -> bool:
    return bool(
        np.isfinite(cmd.q).all()
        and np.isfinite(cmd.dq).all()
        and np.isfinite(cmd.kp).all()
        and np.isfinite(cmd.kd).all()
        and np.isfinite(cmd.tau_ff).all()
    )


def feedback_faults(
    names: tuple[str, ...],
    stamps: list[float | None],
    missed: list[int],
    errors: list[tuple[bool, str]],
    temperatures: list[float | None],
    now: float,
    cfg: SafetyConfig,
) -> list[str]:
    """Reasons the motors' feedback is unsafe right now (empty when all is well)."""
    faults = []
    for name, stamp, miss, (faulted, error), temp in zip(names, stamps, missed, errors, temperatures, strict=True):
        if stamp is None or now - stamp > cfg.reply_timeout:
            age = "never replied" if stamp is None else f"last reply {1e3 * (now - stamp):.0f} ms ago"
            faults.append(f"{name}: motor watchdog ({age}, limit {1e3 * cfg.reply_timeout:.0f} ms)")
        elif miss >= cfg.max_missed_replies:
            faults.append(f"{name}: {miss} replies missed in a row")
        if faulted:
            faults.append(f"{name}: motor error '{error}'")
        if temp is not None and temp > cfg.max_temperature:
            faults.append(f"{name}: over-temperature {temp:.0f} C (limit {cfg.max_temperature:.0f} C)")
    return faults
