"""Bench bring-up through one interface, whatever carries the commands: `BenchRobot`.

A bench script opens a robot from its hardware config (`controller.runtime.bench_robot.open_robot`)
and gets a `BenchRobot`: scan every motor, read the state, move one joint within its limits, sweep
a joint, set an encoder zero (confirmed), damp, read the IMU. The calls are the same on buses
(`hw.bus_bench.BusBenchRobot`, over a `HardwareRobot`) and on a G1 over DDS (`hw.dds.bench.DdsBenchRobot`,
over a `DdsRobot`); this module holds the calls and what they return, and each robot fills in only
what differs: who answered, the IMU's counters, the zero, taking the motors from its own controller.

The robot cycles (500 Hz) only inside a call, through `pump`: one cycle, paced on the wall clock on
a real robot, or one physics step of simulated buses. A moved joint holds its position while calls
run (`hold(seconds)` keeps cycling); between calls the motors keep the last command they got.
Every command passes the robot's own safety layer (limits, the per-cycle step, the feedback
checks). A commanding call first brings the robot up with its soft start, holding the measured
pose; a motion that faults, pushes harder than expected or stops following is ended damped.
"""

from __future__ import annotations

import abc
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol, TypeVar

import numpy as np

from hw import quat
from hw.errors import ConfigError, HardwareFault, LifecycleError, MotorNotFoundError, NotConfirmed
from hw.g1 import CONTROL_CYCLE_HZ
from hw.robot import Lifecycle
from hw.types import JointCommand, LimitedJoint, RobotState

Pump = Callable[[], None]  # one robot cycle, paced
_J = TypeVar("_J")

SCAN_CYCLES = 5  # cycles before a scan reads who answered
REACH_TOLERANCE = 0.05  # rad: a move or a sweep's turning point counts as reached this close
SETTLE_S = 0.5  # at most, at the end of a move and at each turning point of a sweep, for the joint to get there
SETTLED_SPEED = 0.05  # rad/s: a joint this slow, within the tolerance, has settled
MAX_SPEED = 2.0  # rad/s: the fastest a bench move or sweep may go
GRAVITY_MPS2 = 9.81  # what a still accelerometer reads, up


class BenchJoint(LimitedJoint, Protocol):
    """A joint's limits and bring-up gains, as either joint-map kind holds them."""

    @property
    def kp(self) -> float: ...
    @property
    def kd(self) -> float: ...


class Controlled(Protocol):
    """What the bench needs of a robot: the lifecycle `HardwareRobot` and `DdsRobot` share."""

    @property
    def joint_names(self) -> tuple[str, ...]: ...

    state: Lifecycle
    faults: list[str]
    stamp_clock: Callable[[], float]

    def read(self) -> RobotState: ...
    def write(self, command: JointCommand) -> None: ...
    def activate(self, target_pose: np.ndarray | None = None) -> None: ...
    def deactivate(self) -> None: ...
    def enter_damping(self, reason: str) -> None: ...
    def rearm(self) -> None: ...
    def close(self) -> None: ...


@dataclass(frozen=True)
class JointStatus:
    """One joint's motor as the robot last heard it: a row of a scan, or of a monitor."""

    joint: str
    bus: str  # the bus its motor is on ("dds": the G1's main board reports every motor in one LowState_)
    id: int  # the motor's id on its bus (on a G1: its motor slot)
    answered: bool
    q: float | None  # rad, joint side (None: no reply yet)
    dq: float | None  # rad/s
    tau: float | None  # N m
    temperature: float | None  # deg C (None: no reply, or a motor that reports none)
    error: str  # the motor's error state: its name ("ok", "no reply", "motor over-temperature") or bits on a G1
    healthy: bool  # answered, no error, not over the config's max_temperature
    age_ms: float | None  # since its newest reply
    voltage: float | None = None  # V (a G1)
    mode: int | None = None  # the motor's mode as the robot reports it (a G1; 1: enabled)


@dataclass(frozen=True)
class MoveResult:
    joint: str
    target: float  # rad
    position: float  # rad, measured at the end
    reached: bool  # within the tolerance of the target, and holding it
    reason: str  # "reached", why the move stopped (the robot then damped), or how far it settled
    max_abs_torque: float  # N m, measured on the way


@dataclass(frozen=True)
class SweepResult:
    joint: str
    completed: bool  # went through the range and back without a stop
    reason: str  # "completed", or why it stopped (the robot then damped)
    low: float  # rad: the planned range
    high: float
    reached_low: float | None  # rad: where the joint settled at each end (None: the sweep stopped before it)
    reached_high: float | None
    max_abs_torque: float  # N m

    def reached_range(self, tolerance: float = REACH_TOLERANCE) -> bool:
        """Completed, and the joint settled within `tolerance` (rad) of both ends of its range."""
        ends = ((self.reached_low, self.low), (self.reached_high, self.high))
        return self.completed and all(seen is not None and abs(seen - planned) <= tolerance for seen, planned in ends)


@dataclass(frozen=True)
class ZeroResult:
    joint: str
    action: str  # what was done
    zero_offset: float | None  # RS-485 motors have no zero command: the joint map's `zero_offset` that zeroes them here


@dataclass(frozen=True)
class ImuReading:
    """One IMU sample as the robot read it: pelvis orientation in the world, gyro and accelerometer in the IMU frame."""

    time: float  # s, on the robot's clock (when it arrived)
    quaternion_wxyz: tuple[float, float, float, float]
    gyro: tuple[float, float, float]  # rad/s
    accel: tuple[float, float, float]  # m/s^2, specific force: +9.81 up at rest

    def gravity(self) -> tuple[float, float, float]:
        """What the accelerometer would read at rest in this orientation (m/s^2, IMU frame): subtract it for the bias."""
        g = quat.rotate(quat.conjugate(self.quaternion_wxyz), np.array([0.0, 0.0, GRAVITY_MPS2]))
        return float(g[0]), float(g[1]), float(g[2])


@dataclass(frozen=True)
class ImuSummary:
    seconds: float  # the window asked for
    samples: int  # new IMU readings seen in it (at most one a cycle)
    frames: int  # what the IMU sent meanwhile: its frames on buses, the robot's LowState_s on a G1
    rate_hz: float  # samples per second, on the robot's clock
    quaternion_wxyz: list[float]  # the newest
    rpy_deg: list[float]  # the newest, roll pitch yaw
    gyro_mean: list[float]  # rad/s
    gyro_std: list[float]
    accel_mean: list[float]  # m/s^2
    accel_std: list[float]
    crc_errors: int  # in the window
    sequence_gaps: int | None  # frames lost in the window (a serial IMU counts them; None: a G1)


def cycles(seconds: float) -> int:
    """The 500 Hz cycles in `seconds` (at least one)."""
    if not seconds >= 0:
        raise ConfigError(f"seconds must be a number >= 0, got {seconds}")
    return max(round(seconds * CONTROL_CYCLE_HZ), 1)


def joint_config(joints: Mapping[str, _J], name: str) -> _J:
    if name not in joints:
        raise ConfigError(f"unknown joint '{name}' (joints: {', '.join(joints)})")
    return joints[name]


def check_sweep(joints: Mapping[str, _J], name: str, fraction: float, speed: float) -> _J:
    """The swept joint's config; a bad sweep refused in one line (callable before the robot is opened)."""
    joint = joint_config(joints, name)
    if not 0.0 < fraction <= 1.0:
        raise ConfigError(f"a sweep's fraction of the joint's range must be within (0, 1], got {fraction}")
    check_speed(speed)
    return joint


def sweep_range(limits: tuple[float, float], position: float, fraction: float) -> tuple[float, float]:
    """`fraction` of the range `limits`, centred on `position` and shifted as little as it takes to stay within them."""
    lo, hi = limits
    width = (hi - lo) * fraction
    low = min(max(position - width / 2, lo), hi - width)
    return low, low + width


def check_speed(speed: float) -> None:
    if not 0.0 < speed <= MAX_SPEED:
        raise ConfigError(f"speed must be within (0, {MAX_SPEED}] rad/s, got {speed}")


def format_table(rows: Sequence[JointStatus], columns: tuple[str, ...]) -> str:
    """Joint statuses as a text table of `columns` (their field names)."""

    def cell(column: str, v: Any) -> str:
        if v is None:
            return "-"
        if isinstance(v, float):
            return f"{v:.1f}" if column in ("temperature", "voltage", "age_ms") else f"{v:+.3f}"
        return str(v)

    body = [[cell(c, getattr(r, c)) for c in columns] for r in rows]
    widths = [max(len(c), *(len(b[i]) for b in body)) for i, c in enumerate(columns)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(columns, widths, strict=True))]
    lines += ["  ".join(v.ljust(w) for v, w in zip(b, widths, strict=True)) for b in body]
    return "\n".join(lines)


class BenchRobot(abc.ABC):
    """An opened robot for a bench script. Get one from `open_robot` (it damps and closes the robot on exit)."""

    transport: ClassVar[str]  # "buses" or "dds"
    SCAN_COLUMNS: ClassVar[tuple[str, ...]]  # a scan's table (`format_table`)
    MONITOR_COLUMNS: ClassVar[tuple[str, ...]] = ("joint", "q", "dq", "tau", "temperature", "error", "age_ms")

    def __init__(self, robot: Controlled, joints: Mapping[str, BenchJoint], pump: Pump, config_name: str, max_temperature: float) -> None:
        self.robot = robot
        self.joints = joints  # the hardware config's: limits and bring-up gains
        self.config_name = config_name
        self.max_temperature = max_temperature
        self.wire_report: dict[str, Any] | None = None  # simulated robots, once closed: what reached the motors (hw.emulation)
        self._pump = pump
        names = robot.joint_names
        self._kp = np.array([joints[n].kp for n in names])
        self._kd = np.array([joints[n].kd for n in names])
        self._zeros = np.zeros(len(names))
        self._hold: np.ndarray | None = None  # the pose held while active

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.robot.joint_names

    @property
    def state(self) -> Lifecycle:
        return self.robot.state

    # -- reading ---------------------------------------------------------------------
    def hold(self, seconds: float) -> None:
        """Keep cycling for `seconds`: the robot goes on doing what it does (holding, damping, listening)."""
        for _ in range(cycles(seconds)):
            self._pump()

    def read(self) -> RobotState:
        """One cycle, then the newest state: joint positions, velocities and torques in `joint_names` order, the IMU."""
        self._pump()
        return self.robot.read()

    def scan(self) -> list[JointStatus]:
        """A few cycles, then every joint's motor: answered, temperature, error state, healthy."""
        self.hold(SCAN_CYCLES / CONTROL_CYCLE_HZ)
        return self.status()

    @abc.abstractmethod
    def status(self) -> list[JointStatus]:
        """Every joint's motor as last heard, without cycling."""

    def notes(self) -> list[str]:
        """What a scan reports about the robot beyond its motors (a G1: its mode_machine and motion mode)."""
        return []

    # -- commanding ------------------------------------------------------------------
    def move(
        self,
        joint: str,
        position: float,
        speed: float = 0.3,
        tolerance: float = REACH_TOLERANCE,
        torque_fraction: float = 0.3,
        max_tracking_error: float = 0.25,
    ) -> MoveResult:
        """Move one joint to `position` (rad), at most `speed` (rad/s), with its bring-up gains, every other joint holding,
        and hold it there. A position outside the joint's limits is refused, nothing sent. The move stops, damped, on a
        fault, a torque above `torque_fraction` of the joint's limit, or the joint lagging its target by more than
        `max_tracking_error` rad (stuck or blocked)."""
        cfg = joint_config(self.joints, joint)
        lo, hi = cfg.position_limits
        if not (math.isfinite(position) and lo <= position <= hi):
            raise ConfigError(
                f"move {joint} to {position} rad refused: outside its limits [{lo:+.4f}, {hi:+.4f}] rad "
                f"(hardware config '{self.config_name}'); nothing was sent"
            )
        check_speed(speed)
        self._activate()
        index = self.joint_names.index(joint)
        assert self._hold is not None
        motion = self._follow(
            index, [float(self._hold[index]), position], speed, (self._kp, self._kd), torque_fraction * cfg.torque_limit,
            max_tracking_error, tolerance,
        )  # fmt: skip
        measured = float(self.robot.read().joint_pos[index])
        error = abs(measured - position)
        if motion.stop is not None:
            reason = motion.stop
        elif error <= tolerance:
            reason = "reached"
        else:
            reason = f"settled {error:.3f} rad from the target after {SETTLE_S} s (tolerance {tolerance} rad)"
        reached = motion.stop is None and error <= tolerance
        return MoveResult(joint, position, round(measured, 4), reached, reason, round(motion.max_abs_torque, 3))

    def sweep(
        self,
        joint: str,
        fraction: float = 0.3,
        speed: float = 0.3,
        torque_fraction: float = 0.3,
        max_tracking_error: float = 0.25,
    ) -> SweepResult:
        """Move one joint slowly (at most `speed`, rad/s), with half its bring-up stiffness, through `fraction` of its
        range around where it is (within its limits: `sweep_range`), down, up and back, every other joint holding; then
        hold it there. Stops, damped, as `move` does. `reached_range()` says whether it got to both ends."""
        cfg = check_sweep(self.joints, joint, fraction, speed)
        self._activate()
        index = self.joint_names.index(joint)
        assert self._hold is not None
        start = float(self._hold[index])
        low, high = sweep_range(cfg.position_limits, start, fraction)
        kp = self._kp.copy()
        kp[index] *= 0.5  # half the stiffness, all the damping: a soft joint that does not overshoot
        limit = torque_fraction * cfg.torque_limit
        motion = self._follow(index, [start, low, high, start], speed, (kp, self._kd), limit, max_tracking_error, REACH_TOLERANCE)
        at_low, at_high = (round(motion.ends[i], 4) if len(motion.ends) > i else None for i in (0, 1))
        return SweepResult(
            joint=joint, completed=motion.stop is None, reason=motion.stop or "completed", low=round(low, 4), high=round(high, 4),
            reached_low=at_low, reached_high=at_high, max_abs_torque=round(motion.max_abs_torque, 3),
        )  # fmt: skip

    def zero(self, joint: str, *, confirm: bool | Callable[[str], bool]) -> ZeroResult:
        """Set `joint`'s encoder zero at its current position. `confirm`: True, or a function asked the question
        (e.g. a terminal prompt) that says yes; otherwise `NotConfirmed` and nothing is sent. The robot must not be
        holding its joints (`damp()` first). Refused on a G1 over DDS: it has no zero command."""
        self._refuse_zero()
        joint_config(self.joints, joint)
        if self.state in (Lifecycle.ACTIVE, Lifecycle.ACTIVATING):
            raise LifecycleError(f"zero {joint} refused: the robot is holding its joints; damp() first, so that no joint moves")
        silent = self._silent_motors()
        if joint in silent:
            raise MotorNotFoundError(f"zero {joint} refused: its motor ({silent[joint]}) has not answered; nothing was sent")
        position = float(self.read().joint_pos[self.joint_names.index(joint)])
        question = f"set the zero of {joint} at its current position ({position:+.4f} rad) on '{self.config_name}'?"
        if not (confirm if isinstance(confirm, bool) else confirm(question)):
            raise NotConfirmed(f"{question} not confirmed; nothing was sent")
        return self._zero(joint)

    def damp(self, seconds: float = 0.5) -> None:
        """Damping on every joint (kp 0, the config's damping kd) for `seconds` of cycles, latched: the robot stays
        damped until `rearm()`. Closing the robot damps it too."""
        self._take_motors()
        self.robot.enter_damping("damping requested on the bench")
        self._hold = None
        self.hold(seconds)

    def rearm(self) -> None:
        """Leave the damping of a fault or of `damp()` once the motors are healthy; the next move or sweep soft-starts."""
        self.robot.rearm()
        self._hold = None

    # -- the IMU ---------------------------------------------------------------------
    def imu_samples(self, seconds: float = 1.0) -> list[ImuReading]:
        """Every new IMU reading over `seconds` of cycles (at most one a cycle), for logging. Raises if none came."""
        last = self._imu_stamp()  # a robot without an IMU is refused here, before any cycle
        samples: list[ImuReading] = []
        for _ in range(cycles(seconds)):
            self._pump()
            stamp = self._imu_stamp()
            if stamp is not None and stamp != last:
                last = stamp
                state = self.robot.read()
                accel = state.imu_accel if state.imu_accel is not None else self._zeros[:3]
                samples.append(
                    ImuReading(
                        stamp,
                        (float(state.base_quat[0]), float(state.base_quat[1]), float(state.base_quat[2]), float(state.base_quat[3])),
                        (float(state.base_ang_vel[0]), float(state.base_ang_vel[1]), float(state.base_ang_vel[2])),
                        (float(accel[0]), float(accel[1]), float(accel[2])),
                    )
                )
        if not samples:
            raise HardwareFault(self._imu_silent(seconds))
        return samples

    def imu(self, seconds: float = 1.0) -> ImuSummary:
        """The IMU over `seconds`: the newest orientation, the mean and spread of the gyro and accelerometer, counters."""
        frames0, crc0, gaps0 = self._imu_counts()
        t0 = self.robot.stamp_clock()
        samples = self.imu_samples(seconds)
        frames1, crc1, gaps1 = self._imu_counts()
        elapsed = self.robot.stamp_clock() - t0
        gyro, accel = np.array([s.gyro for s in samples]), np.array([s.accel for s in samples])
        newest = samples[-1]

        def rounded(values: np.ndarray, digits: int) -> list[float]:
            return [round(float(v), digits) for v in values]

        return ImuSummary(
            seconds=seconds,
            samples=len(samples),
            frames=frames1 - frames0,
            rate_hz=round(len(samples) / max(elapsed, 1e-9), 1),
            quaternion_wxyz=rounded(np.array(newest.quaternion_wxyz), 5),
            rpy_deg=rounded(np.degrees(quat.rpy(newest.quaternion_wxyz)), 2),
            gyro_mean=rounded(gyro.mean(axis=0), 5),
            gyro_std=rounded(gyro.std(axis=0), 5),
            accel_mean=rounded(accel.mean(axis=0), 4),
            accel_std=rounded(accel.std(axis=0), 4),
            crc_errors=crc1 - crc0,
            sequence_gaps=None if gaps0 is None or gaps1 is None else gaps1 - gaps0,
        )

    def close(self) -> None:
        """Damp and close the robot (`open_robot` does it on exit); safe twice."""
        self.robot.close()

    # -- what each robot fills in ----------------------------------------------------
    @abc.abstractmethod
    def _imu_stamp(self) -> float | None:
        """When the newest IMU reading arrived (None: none yet); raises ConfigError for a robot without an IMU."""

    @abc.abstractmethod
    def _imu_counts(self) -> tuple[int, int, int | None]:
        """The IMU's counters so far: frames (or states) received, CRC errors, sequence gaps (None: not counted)."""

    @abc.abstractmethod
    def _imu_silent(self, seconds: float) -> str:
        """The one line saying no IMU reading came in `seconds`, and what to check."""

    @abc.abstractmethod
    def _zero(self, joint: str) -> ZeroResult:
        """Set the zero (the checks and the confirmation are done)."""

    def _refuse_zero(self) -> None:  # noqa: B027 - a robot without a zero command overrides it
        """Raise where this robot has no zero command."""

    def _silent_motors(self) -> dict[str, str]:
        """The joints whose motors have not answered, each with where its motor is ("bus can0, id 4")."""
        return {}

    def _take_motors(self) -> None:  # noqa: B027 - only a robot with a controller of its own (a G1) overrides it
        """Make the motors this host's before it first commands them."""

    # -- motion ----------------------------------------------------------------------
    def _activate(self) -> None:
        """Soft start holding the measured pose, unless already holding; refused while damped or with silent motors."""
        if self.state is Lifecycle.ACTIVE and self._hold is not None:
            return
        if self.state is Lifecycle.ERROR:
            raise HardwareFault(f"the robot is damped ({'; '.join(self.robot.faults)}): rearm() once it is safe, then command it again")
        silent = self._silent_motors()
        if silent:
            listed = ", ".join(f"{joint} ({where})" for joint, where in silent.items())
            raise MotorNotFoundError(f"motors did not answer: {listed}; nothing was sent: check power, wiring, ids and bitrate")
        self._take_motors()
        pose = self.read().joint_pos.copy()
        if self.state is not Lifecycle.ACTIVE:
            self.robot.activate(target_pose=pose)
            while self.state is Lifecycle.ACTIVATING:
                self._pump()
            if self.state is not Lifecycle.ACTIVE:
                raise HardwareFault(f"soft start failed: {'; '.join(self.robot.faults)}")
        self._hold = pose

    def _follow(
        self,
        index: int,
        waypoints: list[float],
        speed: float,
        gains: tuple[np.ndarray, np.ndarray],
        torque_limit: float,
        max_lag: float,
        tolerance: float,
    ) -> _Motion:
        """Drive joint `index` from `waypoints[0]` through the others, each leg of the way a smoothstep (starting and
        stopping at rest, at most `speed`), settling at each waypoint for up to `SETTLE_S` (within `tolerance` and nearly
        still). A stop damps the robot; otherwise it holds where the motion ended."""
        assert self._hold is not None
        q = self._hold.copy()
        step = speed / CONTROL_CYCLE_HZ
        settle = cycles(SETTLE_S)
        motion = _Motion()
        for a, b in itertools.pairwise(waypoints):
            steps = max(int(1.5 * abs(b - a) / step), 1)  # smoothstep: its peak speed is 1.5 times its mean
            for k in range(1, steps + settle + 1):
                x = min(k, steps) / steps
                q[index] = a + (b - a) * x * x * (3.0 - 2.0 * x)
                self.robot.write(JointCommand(q=q.copy(), dq=self._zeros, kp=gains[0], kd=gains[1], tau_ff=self._zeros))
                state = self.read()
                measured, velocity = float(state.joint_pos[index]), float(state.joint_vel[index])
                tau = 0.0 if state.joint_tau is None else abs(float(state.joint_tau[index]))
                motion.max_abs_torque = max(motion.max_abs_torque, tau)
                lag = abs(measured - q[index])
                if self.state is Lifecycle.ERROR:
                    motion.stop = f"fault: {'; '.join(self.robot.faults)}"
                elif tau > torque_limit:
                    motion.stop = f"unexpected torque {tau:.1f} N m (the limit for this motion {torque_limit:.1f} N m)"
                elif lag > max_lag:
                    motion.stop = f"joint not following: {lag:.2f} rad behind its target (stuck or blocked?), torque {tau:.1f} N m"
                if motion.stop is not None or (k >= steps and abs(measured - b) <= tolerance and abs(velocity) <= SETTLED_SPEED):
                    break
            if motion.stop is not None:
                break
            motion.ends.append(measured)
        if motion.stop is not None:
            self._hold = None
            if self.state is not Lifecycle.ERROR:
                self.robot.deactivate()
        else:
            self._hold[index] = q[index]
            self.robot.write(JointCommand(q=self._hold.copy(), dq=self._zeros, kp=self._kp, kd=self._kd, tau_ff=self._zeros))
        return motion


@dataclass
class _Motion:
    """How a motion of one joint went: why it stopped (None: it did not), where the joint settled at each waypoint
    after the first, the largest torque measured."""

    stop: str | None = None
    ends: list[float] = field(default_factory=list)
    max_abs_torque: float = 0.0
