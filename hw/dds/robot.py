"""The G1 over its low-level DDS topics, with the same lifecycle and safety layer as the bus robot (`hw.lifecycle_robot`).

    UNCONFIGURED --configure--> INACTIVE --activate--> ACTIVATING --ramp done--> ACTIVE
    ACTIVE/ACTIVATING --deactivate--> INACTIVE (damping, then no more commands)
    any --fault--> ERROR (damping every cycle, latched) --rearm--> INACTIVE

configure: wait for the first `LowState_` with a good CRC and learn `mode_machine`, then release
the robot's high-level motion service (when the config asks). `cycle()` is one 500 Hz exchange: the
newest joint command through the safety layer (limits, per-cycle step, soft-start ramp) out as
one `LowCmd_`, then the newest `LowState_` in and its checks: stale state (robot gone, cable
out), bad CRCs in a row, a changed `mode_machine`, motor error bits (`motorstate`), motor
temperature, non-finite values. Any fault latches damping (kp 0, kd `damping_kd`) on every joint.
In INACTIVE nothing is sent: the robot's own controller keeps the motors limp.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from hw import g1
from hw.dds import cdr
from hw.dds.cdr import JointArrays
from hw.dds.config import DdsHardwareConfig
from hw.dds.link import DdsLink, LinkCounters
from hw.errors import LifecycleError
from hw.lifecycle_robot import LifecycleRobot
from hw.protocols import unitree_hg as hg
from hw.robot import Lifecycle
from hw.safety import JointLimits
from hw.types import JointCommand, RobotState

log = logging.getLogger(__name__)

NON_FINITE = "non-finite values in the robot's state"
DEACTIVATE_DAMPING_CYCLES = 3  # damping frames sent on deactivate before the host falls silent


@dataclass(frozen=True)
class JointReading:
    """One joint as the robot last reported it (the `hw scan` and `hw monitor` rows)."""

    name: str
    q: float
    dq: float
    tau: float
    temperature: float  # deg C, the hotter of the motor's two sensors
    voltage: float
    error_bits: int  # MotorState_.motorstate: 0 when healthy
    mode: int  # the motor's mode as the robot reports it (1: enabled)


class DdsRobot(LifecycleRobot):
    def __init__(
        self,
        cfg: DdsHardwareConfig,
        joint_names: tuple[str, ...] = g1.JOINT_NAMES,
        default_pose: tuple[float, ...] | None = None,
        clock: Callable[[], float] = time.monotonic,
        release: Callable[[Any], str | None] | None = None,
    ) -> None:
        """`release(session)` frees the robot from its high-level motion service (default: the motion switcher)."""
        if joint_names != g1.JOINT_NAMES:
            raise LifecycleError("the G1 over DDS has the G1's 29 joints in the standard order (motor slots 0..28)")
        gains = (np.array([cfg.joints[n].kp for n in joint_names]), np.array([cfg.joints[n].kd for n in joint_names]))
        pose = np.asarray(default_pose if default_pose is not None else g1.default_joint_vector(), float)
        super().__init__(joint_names, pose, clock, JointLimits.from_joint_map(joint_names, cfg.joints), gains, cfg.safety)
        self.cfg = cfg
        self._release = release
        self.released_mode: str | None = None  # the high-level mode released (at configure, or later by `release_motion_service`)
        self._commanded = False  # the robot is this host's to command (released, activated, damped): only then does it send
        self.link: DdsLink | None = None
        self._closed_counters = LinkCounters()
        n = len(joint_names)
        self._quat, self._gyro, self._accel = np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.zeros(3)
        self._temperature, self._error_bits = np.zeros(n), np.zeros(n, dtype=np.uint32)
        self._applied: JointArrays | None = None  # the state the joint arrays were last filled from
        self._template = hg.new_low_cmd(mode_pr=cfg.mode_pr)
        self._template["motor_cmd"]["mode"][: g1.NUM_JOINTS] = hg.MOTOR_ENABLE

    # -- lifecycle -------------------------------------------------------------------
    def configure(self) -> None:
        """Join the robot's domain, wait for its first good `LowState_`, release its high-level motion service."""
        if self.state is not Lifecycle.UNCONFIGURED:
            raise LifecycleError(f"configure needs the robot unconfigured, it is {self.state.value}")
        self.link = DdsLink(self.cfg.dds, self.stamp_clock)
        try:
            self.link.connect(self.cfg.connect_timeout)
            if self.cfg.release_motion_service:
                self.release_motion_service()
        except Exception:
            self._close_link()
            raise
        self._update_state()
        self.state = Lifecycle.INACTIVE

    def release_motion_service(self) -> None:
        """Free the robot from its high-level motion service: its motors are this host's from now on, and every exit
        damps them. `configure` does it when the config asks; a host that configured only to listen (a bench scan)
        calls it before it first commands."""
        if self.link is None:
            raise LifecycleError(f"releasing the motion service needs a connected robot, it is {self.state.value}")
        if self._release is not None:
            self.released_mode = self._release(self.link.session)
        else:
            from hw.dds.motion_switcher import release_motion_service  # noqa: PLC0415

            self.released_mode = release_motion_service(self.link.session)
        self._commanded = True

    def activate(self, target_pose: np.ndarray | None = None) -> None:
        """Soft start: from the measured pose, ramp to `target_pose` (default: the default pose) over `soft_start_time`."""
        if self.state is not Lifecycle.INACTIVE:
            raise LifecycleError(f"activate needs the robot inactive, it is {self.state.value}")
        self._commanded = True  # from here on this host commands the robot: every exit damps it
        self._receive()
        self._update_state()
        self._start_ramp(target_pose)

    def deactivate(self) -> None:
        """Damping for a few cycles, then silence (the robot's controller then holds the motors limp)."""
        if self.state in (Lifecycle.UNCONFIGURED, Lifecycle.CLOSED) or not self._commanded:
            return
        for i in range(DEACTIVATE_DAMPING_CYCLES):  # one per cycle: the robot keeps only the newest command it has not applied
            if i:
                time.sleep(1.0 / g1.CONTROL_CYCLE_HZ)
            self._damp_now()
        if self.state is not Lifecycle.ERROR:
            self.state = Lifecycle.INACTIVE
        self._ramp, self._command = None, None
        self._forget_settled()

    def rearm(self) -> None:
        """Leave ERROR once the robot's newest state is healthy again; the robot is then INACTIVE."""
        if self.link is not None:
            self._receive()
        super().rearm()

    # -- control ---------------------------------------------------------------------
    def enter_damping(self, reason: str) -> None:
        """Latch damping on purpose (not a fault): every cycle damps until `rearm()`."""
        self._commanded = True
        super().enter_damping(reason)

    def cycle(self, wait_s: float = 0.0) -> None:
        """One exchange: the command (or damping) out, then the newest state in and its checks.

        `wait_s`: how long to wait for a state after sending (the benchmark's lock-step robot
        answers each command; the real robot publishes on its own 2 ms clock: 0).
        """
        self.cycles += 1
        if self.state in (Lifecycle.UNCONFIGURED, Lifecycle.CLOSED) or self.link is None:
            raise LifecycleError(f"cycle needs a configured robot, it is {self.state.value}")
        if self.state in (Lifecycle.ACTIVE, Lifecycle.ACTIVATING):
            self._send(self._next_command())
        elif self.state is Lifecycle.ERROR:
            self._damp_now()
        if wait_s > 0:
            self.link.wait(wait_s)
        self._receive()
        if self.state in (Lifecycle.ACTIVE, Lifecycle.ACTIVATING):
            faults = self._cycle_faults()
            if faults:
                self._enter_error(faults)

    def _send(self, command: JointCommand) -> None:
        assert self.link is not None
        if command is not self._encoded[0]:
            motors = self._template["motor_cmd"]
            n = g1.NUM_JOINTS
            motors["q"][:n], motors["dq"][:n], motors["tau"][:n] = command.q, command.dq, command.tau_ff
            motors["kp"][:n], motors["kd"][:n] = command.kp, command.kd
            self._encoded = (command, self.link.encode(self._template))
        self.link.send_cdr(self._encoded[1])

    def _damp_now(self) -> None:
        """Damping, once the robot is this host's (a host that only listened sends nothing)."""
        if self.link is not None and self._commanded:
            self._update_state()  # damping holds no position, but a command carries the measured one
            self._send(JointCommand(q=self._q, dq=self._zeros, kp=self._zeros, kd=self._damp_kd, tau_ff=self._zeros))

    def _receive(self) -> None:
        assert self.link is not None
        self.link.poll()

    def _refresh(self) -> None:
        self._update_state()

    def _update_state(self) -> None:
        """The newest state's joints and IMU into the robot's arrays; only when someone reads them (the 500 Hz checks read in place)."""
        arrays = None if self.link is None else self.link.arrays
        if arrays is None or arrays is self._applied:
            return
        self._applied = arrays
        motion = arrays.motion
        self._q[:], self._dq[:], self._tau[:] = motion[:, 0], motion[:, 1], motion[:, 3]
        self._temperature[:] = arrays.temperature.max(axis=1)
        self._error_bits[:] = arrays.motorstate
        self._quat[:], self._gyro[:], self._accel[:] = arrays.imu[:4], arrays.imu[4:7], arrays.imu[7:10]

    def _check_feedback(self) -> list[str]:
        """Everything wrong with the robot's state now (activation, re-arm): the cycle's checks and non-finite values."""
        return self._fault_reasons(self.stamp_clock())

    def _cycle_faults(self) -> list[str]:
        """The checks every cycle runs, the common case in one expression: staleness, bad CRCs, `mode_machine`, error
        bits, temperature. Non-finite values are checked where the state is used (`read`); any doubt is spelled out."""
        link, safety = self.link, self.cfg.safety
        assert link is not None
        now = self.stamp_clock()
        if (
            link.data is not None
            and now - link.state_time <= safety.state_timeout
            and link.counters.bad_in_a_row < safety.max_bad_states
            and link.reported_mode_machine == link.mode_machine
        ):
            health = cdr.state_health(link.data)
            if not health.error_bits and health.max_temperature <= safety.max_temperature:
                return []
        return [f for f in self._fault_reasons(now) if not f.startswith(NON_FINITE)]

    def _fault_reasons(self, now: float) -> list[str]:
        assert self.link is not None
        safety, counters = self.cfg.safety, self.link.counters
        faults: list[str] = []
        age = now - self.link.state_time
        if not age <= safety.state_timeout:
            last = "none yet" if math.isinf(age) else f"the last {1e3 * age:.0f} ms ago"
            faults.append(f"robot state stale: no good LowState_ within {1e3 * safety.state_timeout:.0f} ms ({last})")
        if counters.bad_in_a_row >= safety.max_bad_states:
            faults.append(f"{counters.bad_in_a_row} LowState_s in a row with a bad CRC: the link corrupts data")
        if self.link.reported_mode_machine != self.link.mode_machine:
            faults.append(
                f"the robot's mode_machine changed from {self.link.mode_machine} to {self.link.reported_mode_machine}: "
                "it refuses commands stamped with the old one (another robot on this domain, or it restarted)"
            )
        arrays = self.link.arrays
        if arrays is None:
            return faults
        if arrays.motorstate.any() or arrays.temperature.max() > safety.max_temperature:
            self._update_state()
            faults += [f"{self._names[i]}: motor error bits {int(self._error_bits[i]):#010x}" for i in np.flatnonzero(self._error_bits)]
            hot = np.flatnonzero(self._temperature > safety.max_temperature)
            faults += [
                f"{self._names[i]}: over-temperature {self._temperature[i]:.0f} C (limit {safety.max_temperature:.0f} C)" for i in hot
            ]
        if not math.isfinite(float(arrays.motion.sum()) + float(arrays.imu.sum())):
            bad = [self._names[i] for i in np.flatnonzero(~np.isfinite(arrays.motion).all(axis=1))]
            faults.append(f"{NON_FINITE} ({', '.join(bad) or 'IMU'})")
        return faults

    def _enter_error(self, faults: list[str]) -> None:
        link = self.link
        if link is not None and link.reported_mode_machine is not None and link.reported_mode_machine != link.mode_machine:
            # The robot refuses commands stamped with another mode_machine: damping goes out with the one it reports now.
            link.mode_machine = link.reported_mode_machine
        super()._enter_error(faults)

    # -- reading ---------------------------------------------------------------------
    def read(self) -> RobotState:
        """The newest state; a non-finite value in it latches damping before anything can use it."""
        self._update_state()
        finite = math.isfinite(float(self._q.sum() + self._dq.sum() + self._quat.sum() + self._gyro.sum()))
        if not finite and self.state not in (Lifecycle.UNCONFIGURED, Lifecycle.CLOSED, Lifecycle.ERROR):
            self._enter_error([f for f in self._fault_reasons(self.stamp_clock()) if f.startswith(NON_FINITE)] or [NON_FINITE])
        return RobotState(
            time=self.stamp_clock(),
            joint_pos=self._q.copy(),
            joint_vel=self._dq.copy(),
            base_quat=self._quat.copy(),
            base_ang_vel=self._gyro.copy(),
            base_pos=np.zeros(3),  # the low-level state has no base position
            base_lin_vel=np.zeros(3),
            has_base_position=False,
            imu_accel=self._accel.copy(),
            joint_tau=self._tau.copy(),
        )

    def joints(self) -> list[JointReading]:
        """Every joint as the robot last reported it."""
        self._update_state()
        record = self.low_state
        if record is None:
            return []
        motors = record["motor_state"]
        rows = zip(
            self._names, self._q, self._dq, self._tau, self._temperature, motors["vol"], self._error_bits, motors["mode"], strict=False
        )
        return [JointReading(n, float(q), float(dq), float(t), float(c), float(v), int(e), int(m)) for n, q, dq, t, c, v, e, m in rows]

    @property
    def low_state(self) -> np.ndarray | None:
        """The newest good `LowState_` record (IMU, tick, the remote's bytes); None before configure and after close."""
        return None if self.link is None else self.link.state

    def state_age(self) -> float:
        """Seconds since the newest good `LowState_` arrived."""
        return math.inf if self.link is None else self.stamp_clock() - self.link.state_time

    def counters(self) -> LinkCounters:
        if self.link is None:
            return self._closed_counters
        return self.link.counters

    # -- shutdown --------------------------------------------------------------------
    def _shutdown(self) -> None:
        try:
            self.deactivate()
        finally:
            self._close_link()
            self.state = Lifecycle.CLOSED

    def _close_link(self) -> None:
        if self.link is not None:
            self._closed_counters = self.link.counters
            self.link.close()
            self.link = None
