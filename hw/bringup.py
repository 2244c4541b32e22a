"""Bench bring-up operations on a `HardwareRobot`: scan, monitor, zero, sweep, damp, IMU.

Each takes a `pump` callable that runs one bus cycle and paces it (`CONTROL_CYCLE_HZ` on
real hardware; one physics step on simulated hardware), so the same code drives both.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np

from hw import quat
from hw.drivers import MitBusDriver
from hw.errors import ConfigError, HardwareFault
from hw.g1 import CONTROL_CYCLE_HZ
from hw.hardware_robot import HardwareRobot, Lifecycle
from hw.jointmap import JointConfig, motor_to_joint
from hw.protocols import mit
from hw.types import JointCommand, RobotState

Pump = Callable[[], None]
_J = TypeVar("_J")


def probe(host: HardwareRobot) -> list[dict[str, Any]]:
    """Every configured motor with what it answered (or that it did not): the `hw scan` table."""
    rows = []
    for name in host.joint_names:
        joint = host.cfg.joints[name]
        fb = host.feedback(name)
        answered = fb.stamp is not None
        q = motor_to_joint(joint, fb.position, fb.velocity, fb.torque)[0] if answered else None
        rows.append(
            {
                "bus": joint.bus,
                "id": joint.id,
                "joint": name,
                "answered": answered,
                "position": None if q is None else round(q, 4),
                "temperature": fb.temperature,
                "error": fb.error if answered else "no reply",
            }
        )
    return rows


def format_table(rows: list[dict[str, Any]], columns: tuple[str, ...]) -> str:
    def cell(column: str, v: Any) -> str:
        if v is None:
            return "-"
        if isinstance(v, float):
            return f"{v:.1f}" if column in ("temperature", "temp", "voltage", "age_ms") else f"{v:+.3f}"
        return str(v)

    body = [[cell(c, r.get(c)) for c in columns] for r in rows]
    widths = [max(len(c), *(len(b[i]) for b in body)) for i, c in enumerate(columns)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(columns, widths, strict=True))]
    lines += ["  ".join(v.ljust(w) for v, w in zip(b, widths, strict=True)) for b in body]
    return "\n".join(lines)


def monitor_rows(host: HardwareRobot) -> list[dict[str, Any]]:
    state = host.read()
    rows = []
    for i, name in enumerate(host.joint_names):
        fb = host.feedback(name)
        torque = motor_to_joint(host.cfg.joints[name], fb.position, fb.velocity, fb.torque)[2]
        rows.append(
            {
                "joint": name,
                "q": float(state.joint_pos[i]),
                "dq": float(state.joint_vel[i]),
                "tau": torque,
                "temp": fb.temperature,
                "error": fb.error,
                "age_ms": None if fb.stamp is None else round(1e3 * (host.stamp_clock() - fb.stamp), 1),
            }
        )
    return rows


def zero(host: HardwareRobot, joint_name: str) -> dict[str, Any]:
    """MIT motors: set the encoder zero at the current position. RS-485 motors have no
    zero command: the joint map's `zero_offset` that makes the current position read 0."""
    joint = _joint(host, joint_name)
    slot_driver = host.driver_of(joint_name)
    if isinstance(slot_driver, MitBusDriver):
        slot_driver.send_special(mit.SET_ZERO, (joint.id,))
        slot_driver.collect_now(0.02)
        return {"joint": joint_name, "action": "encoder zero set on the motor"}
    fb = host.feedback(joint_name)
    position = motor_to_joint(joint, fb.position, 0.0, 0.0)[0] - joint.zero_offset
    return {"joint": joint_name, "action": "no zero command on this protocol", "zero_offset": round(-position, 6)}


@dataclass(frozen=True)
class SweepResult:
    joint: str
    completed: bool
    reason: str
    low: float
    high: float
    max_abs_torque: float


class SweepJoint(Protocol):
    """What a sweep needs of a joint's config (a bus `JointConfig` or a DDS `DdsJointConfig`)."""

    @property
    def position_limits(self) -> tuple[float, float]: ...
    @property
    def torque_limit(self) -> float: ...
    @property
    def kp(self) -> float: ...
    @property
    def kd(self) -> float: ...


class SweepRobot(Protocol):
    """What a sweep needs of a robot: the lifecycle of `HardwareRobot` and `DdsRobot` alike."""

    @property
    def joint_names(self) -> tuple[str, ...]: ...
    @property
    def state(self) -> Lifecycle: ...
    @property
    def faults(self) -> list[str]: ...
    def read(self) -> RobotState: ...
    def write(self, command: JointCommand) -> None: ...
    def activate(self, target_pose: np.ndarray | None = None) -> None: ...
    def deactivate(self) -> None: ...


def sweep(
    host: HardwareRobot,
    joint_name: str,
    pump: Pump,
    fraction: float = 0.3,
    speed: float = 0.3,
    torque_fraction: float = 0.3,
    max_tracking_error: float = 0.25,
) -> SweepResult:
    """`sweep_joint` on the buses: the joint's torque from its motor's feedback."""

    def torque() -> float:
        fb = host.feedback(joint_name)
        return motor_to_joint(host.cfg.joints[joint_name], fb.position, fb.velocity, fb.torque)[2]

    return sweep_joint(host, host.cfg.joints, joint_name, torque, pump, fraction, speed, torque_fraction, max_tracking_error)


def sweep_joint(
    host: SweepRobot,
    joints: Mapping[str, SweepJoint],
    joint_name: str,
    torque: Callable[[], float],
    pump: Pump,
    fraction: float = 0.3,
    speed: float = 0.3,
    torque_fraction: float = 0.3,
    max_tracking_error: float = 0.25,
) -> SweepResult:
    """Move one joint slowly, with half its bring-up gains, through `fraction` of its range
    around the middle and back to where it started; every other joint holds its position.
    Aborts on any fault, a torque above `torque_fraction` of the joint's limit (`torque()`:
    the joint's newest torque, N m), or the joint lagging its target by more than
    `max_tracking_error` rad (stuck or blocked)."""
    joint = check_sweep(joints, joint_name, host.joint_names, fraction, speed)
    index = host.joint_names.index(joint_name)
    lo, hi = joint.position_limits
    mid, half = (lo + hi) / 2, (hi - lo) * fraction / 2
    low, high = mid - half, mid + half
    hold_pose = host.read().joint_pos.copy()
    host.activate(target_pose=hold_pose)
    while host.state is Lifecycle.ACTIVATING:
        pump()
    start = hold_pose[index]
    waypoints = [start, low, high, start]
    kp = np.array([joints[n].kp for n in host.joint_names])
    kd = np.array([joints[n].kd for n in host.joint_names])
    kp[index] *= 0.5
    kd[index] *= 0.5
    q = hold_pose.copy()
    limit = torque_fraction * joint.torque_limit
    max_tau = 0.0
    dt = 1.0 / CONTROL_CYCLE_HZ
    reason = "completed"
    for a, b in itertools.pairwise(waypoints):
        steps = max(int(abs(b - a) / (speed * dt)), 1)
        for k in range(1, steps + 1):
            q[index] = a + (b - a) * k / steps
            host.write(JointCommand(q=q.copy(), dq=np.zeros_like(q), kp=kp, kd=kd, tau_ff=np.zeros_like(q)))
            pump()
            tau = abs(torque())
            max_tau = max(max_tau, tau)
            if host.state is Lifecycle.ERROR:
                reason = f"fault: {'; '.join(host.faults)}"
                break
            if tau > limit:
                reason = f"unexpected torque {tau:.1f} N m (limit for the sweep {limit:.1f} N m)"
                break
            lag = abs(host.read().joint_pos[index] - q[index])
            if lag > max_tracking_error:
                reason = f"joint not following: {lag:.2f} rad behind its target (stuck or blocked?), torque {tau:.1f} N m"
                break
        if reason != "completed":
            break
    host.deactivate()
    return SweepResult(joint_name, reason == "completed", reason, round(low, 4), round(high, 4), round(max_tau, 3))


def damp(host: HardwareRobot, pump: Pump, seconds: float = 2.0) -> None:
    """Damping on every joint for `seconds` (the motors keep it until they time out or are re-commanded)."""
    host.enter_damping("damping requested by 'g1ctl hw damp'")
    for _ in range(max(int(seconds * CONTROL_CYCLE_HZ), 1)):
        pump()


def imu_summary(host: HardwareRobot, pump: Pump, seconds: float = 1.0) -> dict[str, Any]:
    if host.imu is None:
        raise ConfigError("this hardware config has no IMU (add an 'imu' section with its serial bus)")
    for _ in range(max(int(seconds * CONTROL_CYCLE_HZ), 1)):
        pump()
    sample = host.imu.latest
    if sample is None:
        raise HardwareFault(f"no valid IMU frame in {seconds} s on '{host.imu.name}'; check the port, baud rate and wiring")
    rpy = quat.rpy(sample.quaternion).tolist()
    c = host.imu.counters
    return {
        "quaternion_wxyz": [round(v, 5) for v in sample.quaternion],
        "rpy_deg": [round(math.degrees(v), 2) for v in rpy],
        "angular_velocity": [round(v, 4) for v in sample.angular_velocity],
        "linear_acceleration": [round(v, 3) for v in sample.linear_acceleration],
        "frames": c.frames,
        "crc_errors": c.crc_errors,
        "sequence_gaps": c.sequence_gaps,
        "rate_hz": round(c.frames / seconds, 1),
    }


def check_sweep(joints: Mapping[str, _J], joint_name: str, names: tuple[str, ...], fraction: float, speed: float) -> _J:
    """The swept joint's config; a bad sweep refused in one line (callable before the robot is opened)."""
    joint = _joint_config(joints, joint_name, names)
    if not 0.0 < fraction <= 1.0:
        raise ConfigError(f"--fraction must be within (0, 1], got {fraction}")
    if not 0.0 < speed <= 2.0:
        raise ConfigError(f"--speed must be within (0, 2] rad/s, got {speed}")
    return joint


def _joint(host: HardwareRobot, name: str) -> JointConfig:
    return _joint_config(host.cfg.joints, name, host.joint_names)


def _joint_config(joints: Mapping[str, _J], name: str, names: tuple[str, ...]) -> _J:
    if name not in joints:
        raise ConfigError(f"unknown joint '{name}' (joints: {', '.join(names)})")
    return joints[name]
