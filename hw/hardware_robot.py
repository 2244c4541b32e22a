"""The robot over real (or simulated) buses, with a ros2_control-shaped lifecycle.

    UNCONFIGURED --configure--> INACTIVE --activate--> ACTIVATING --ramp done--> ACTIVE
    ACTIVE/ACTIVATING --deactivate--> INACTIVE (damping, then motors disabled)
    any --fault--> ERROR (damping every cycle, latched) --rearm--> INACTIVE

The lifecycle and the command path are `hw.lifecycle_robot`'s, shared with the G1 over DDS.
`cycle()` is one exchange with every motor (the 500 Hz writer calls it): it turns the
newest joint command into motor frames through the safety layer, sends them on every
bus, collects the replies and runs the feedback checks. The controller only calls
`write()` (newest command) and `read()` (newest state).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable

import numpy as np

from hw import g1
from hw.drivers import BusCounters, MitBusDriver, MitMotor, Rs485BusDriver
from hw.errors import BusError, LifecycleError, MotorNotFoundError
from hw.feedback import FeedbackStore, MitReplyBank, MotorFeedback
from hw.imu import SerialImu
from hw.jointmap import HardwareConfig, JointConfig, load_motor_models
from hw.lifecycle_robot import LifecycleRobot
from hw.protocols import mit
from hw.robot import Lifecycle
from hw.safety import JointLimits, feedback_faults
from hw.transport import open_can, open_serial
from hw.types import JointCommand, RobotState

log = logging.getLogger(__name__)


class HardwareRobot(LifecycleRobot):
    def __init__(
        self,
        cfg: HardwareConfig,
        joint_names: tuple[str, ...] = g1.JOINT_NAMES,
        default_pose: tuple[float, ...] | None = None,
        stamp_clock: Callable[[], float] = time.monotonic,
        await_replies: Callable[[], None] | None = None,
    ) -> None:
        """`await_replies` (simulated hardware): returns once every frame sent on the CAN buses has been answered
        or its reply dropped; the replies are then taken without waiting on the wall clock (`cycle_timeout`)."""
        gains = (np.array([cfg.joints[n].kp for n in joint_names]), np.array([cfg.joints[n].kd for n in joint_names]))
        pose = np.asarray(default_pose if default_pose is not None else g1.default_joint_vector(), float)
        super().__init__(joint_names, pose, stamp_clock, JointLimits.from_joint_map(joint_names, cfg.joints), gains, cfg.safety)
        self.cfg = cfg
        self._drivers: dict[str, MitBusDriver | Rs485BusDriver] = {}
        self._closed_counters = BusCounters()  # of buses already closed
        self.store = FeedbackStore(len(joint_names))
        self._slot_of: dict[str, tuple[MitBusDriver | Rs485BusDriver, int]] = {}  # joint -> (driver, motor id)
        self.imu: SerialImu | None = None
        self._has_serial = False
        self._await_replies = await_replies
        self._motors_disabled = False  # the MIT motors were sent out of motor mode (deactivate): activate enables them

    # -- lifecycle -------------------------------------------------------------------
    def configure(self, require_all: bool = True) -> None:
        """Open every bus and port, find every configured motor; fail naming the missing ones
        (with `require_all=False`, as `hw scan` does, the missing ones are only left without feedback)."""
        if self.state is not Lifecycle.UNCONFIGURED:
            raise LifecycleError(f"configure needs the robot unconfigured, it is {self.state.value}")
        try:
            if not self._drivers:
                self._open()
            missing = self._discover()
        except Exception:
            self._close_buses()
            raise
        if missing and require_all:
            self._close_buses()
            raise MotorNotFoundError(f"motors did not answer: {', '.join(missing)}; check power, wiring, ids and bitrate")
        self.state = Lifecycle.INACTIVE

    def open(self) -> None:
        """Open every bus and port of the config, and speak to no motor yet (`configure` opens them if this was not
        called). A bus that cannot be opened is one `BusError` naming it and why; the ones already open are closed."""
        if self.state is not Lifecycle.UNCONFIGURED:
            raise LifecycleError(f"open needs the robot unconfigured, it is {self.state.value}")
        if self._drivers:
            return
        try:
            self._open()
        except Exception:
            self._close_buses()
            raise

    def _open(self) -> None:
        models = load_motor_models()
        by_bus: dict[str, list[tuple[str, JointConfig]]] = {}
        for name in self._names:
            joint = self.cfg.joints[name]
            by_bus.setdefault(joint.bus, []).append((name, joint))
        index_of = {name: i for i, name in enumerate(self._names)}
        n = len(self._names)
        self.store = FeedbackStore(n)
        mit_joints = [(name, j) for joints in by_bus.values() for name, j in joints if self.cfg.buses[j.bus].kind == "can"]
        self._mit_index = np.array([index_of[name] for name, _ in mit_joints], dtype=np.int64)  # robot MIT order: bus by bus
        ranges = {
            f: np.array([getattr(models[j.model], f) for _, j in mit_joints], float)
            for f in ("p_max", "v_max", "t_max", "kp_max", "kd_max")
        }
        self._mit_ranges = tuple(ranges.values())
        self._replies = MitReplyBank(self._mit_index.tolist(), [models[j.model] for _, j in mit_joints], [j.reply for _, j in mit_joints])
        first_row = 0
        for bus_name, joints in by_bus.items():
            bus_cfg = self.cfg.buses[bus_name]
            index = [index_of[name] for name, _ in joints]
            if bus_cfg.kind == "can":
                motors = [MitMotor(j.id, models[j.model], j.reply) for _, j in joints]
                bus = open_can(bus_name, bus_cfg)
                driver: MitBusDriver | Rs485BusDriver = MitBusDriver(
                    bus_name, bus, motors, index, self.store, self._replies, first_row, self.stamp_clock
                )
                first_row += len(index)
            else:
                port = open_serial(bus_name, bus_cfg)
                driver = Rs485BusDriver(bus_name, port, [j.id for _, j in joints], index, self.store, self.stamp_clock)
            self._drivers[bus_name] = driver
            for name, j in joints:
                self._slot_of[name] = (driver, j.id)
        self._has_serial = any(isinstance(d, Rs485BusDriver) for d in self._drivers.values())
        self._sign = np.array([self.cfg.joints[n].direction for n in self._names], float)
        self._gear = np.array([self.cfg.joints[n].gear_ratio for n in self._names])
        self._q_scale, self._tau_scale = self._sign / self._gear, self._sign * self._gear  # motor side -> joint side
        self._offset = np.array([self.cfg.joints[n].zero_offset for n in self._names])
        self._all_replied = False
        if self.cfg.imu is not None:
            bus_cfg = self.cfg.buses[self.cfg.imu.bus]
            self.imu = SerialImu(self.cfg.imu.bus, open_serial(self.cfg.imu.bus, bus_cfg), self.stamp_clock)

    def _discover(self) -> list[str]:
        """Enable motor mode limp (zero gains) and collect one reply from each motor."""
        self._enter_motor_mode()
        self._exchange(limp=True, timeout=0.05)
        return [f"{n} (bus {self.cfg.joints[n].bus}, id {self.cfg.joints[n].id})" for n in self._names if self.feedback(n).stamp is None]

    def _enter_motor_mode(self) -> None:
        """Enable the MIT motors (RS-485 motors are enabled by every command that asks)."""
        for driver in self._drivers.values():
            if isinstance(driver, MitBusDriver):
                driver.send_special(mit.ENTER_MOTOR_MODE)
                driver.collect(self._replies_deadline(time.monotonic() + 0.05))
        self._motors_disabled = False

    def activate(self, target_pose: np.ndarray | None = None) -> None:
        """Soft start: from the measured pose, ramp to `target_pose` (default: the default pose) over `soft_start_time`.
        After a `deactivate` the MIT motors are enabled again first."""
        if self.state is not Lifecycle.INACTIVE:
            raise LifecycleError(f"activate needs the robot inactive, it is {self.state.value}")
        if self._motors_disabled:
            self._enter_motor_mode()
        self._await_first_imu_frame()
        self._exchange(limp=True, timeout=self.cfg.safety.cycle_timeout * 4)
        self._update_state()
        self._start_ramp(target_pose)

    def _await_first_imu_frame(self) -> None:
        """Give the IMU's first frame up to its timeout (wall clock) to arrive before the activation check.

        A frame sent just before activation may still sit in the port's buffers (a
        pseudo-terminal hands data over on a kernel worker, late on a loaded machine); without
        this wait such an IMU reads as stale and activation fails for nothing.
        """
        if self.imu is None or self.cfg.imu is None:
            return
        deadline = time.monotonic() + self.cfg.imu.timeout
        self.imu.poll()
        while self.imu.stamp is None and self.imu.port_fault is None and time.monotonic() < deadline:
            time.sleep(0.001)
            self.imu.poll()

    def deactivate(self) -> None:
        """Damping, then disable every motor."""
        if self.state in (Lifecycle.UNCONFIGURED, Lifecycle.CLOSED):
            return
        for _ in range(3):
            self._exchange(limp=False, damping=True)
        for driver in self._drivers.values():
            if isinstance(driver, MitBusDriver):
                driver.send_special(mit.EXIT_MOTOR_MODE)
                driver.collect(self._replies_deadline(time.monotonic() + self.cfg.safety.cycle_timeout))
        self._motors_disabled = True
        self._exchange(limp=True)
        if self.state is not Lifecycle.ERROR:
            self.state = Lifecycle.INACTIVE
        self._ramp, self._command = None, None
        self._forget_settled()

    # -- control ---------------------------------------------------------------------
    def _damp_now(self) -> None:
        if self._drivers:
            self._exchange(limp=False, damping=True)

    def _refresh(self) -> None:
        self._update_state()

    def driver_of(self, joint_name: str) -> MitBusDriver | Rs485BusDriver:
        return self._slot_of[joint_name][0]

    def read(self) -> RobotState:
        quat, gyro, accel = np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), None
        if self.imu is not None and self.imu.latest is not None:
            sample = self.imu.latest
            quat, gyro, accel = np.array(sample.quaternion), np.array(sample.angular_velocity), np.array(sample.linear_acceleration)
        return RobotState(
            time=self.stamp_clock(),
            joint_pos=self._q.copy(),
            joint_vel=self._dq.copy(),
            base_quat=quat,
            base_ang_vel=gyro,
            base_pos=np.zeros(3),  # the buses measure no base position: `controller.estimation` estimates it
            base_lin_vel=np.zeros(3),
            has_base_position=False,
            imu_accel=accel,
            joint_tau=self._tau.copy(),
        )

    def cycle(self) -> None:
        """One exchange with every motor, then the feedback checks."""
        self.cycles += 1
        if self.state in (Lifecycle.UNCONFIGURED, Lifecycle.CLOSED):
            raise LifecycleError(f"cycle needs a configured robot, it is {self.state.value}")
        if self.state in (Lifecycle.ACTIVE, Lifecycle.ACTIVATING):
            self._exchange(limp=False, command=self._next_command())
        elif self.state is Lifecycle.ERROR:
            self._exchange(limp=False, damping=True)
        else:
            self._exchange(limp=True)
        self._update_state()
        if self.state in (Lifecycle.ACTIVE, Lifecycle.ACTIVATING):
            faults = self._check_feedback()
            if faults:
                self._enter_error(faults)

    def _motor_side(self, limp: bool, damping: bool, command: JointCommand | None) -> tuple[np.ndarray, ...]:
        """Joint side -> motor side for every joint at once (`hw.jointmap.joint_to_motor` on arrays)."""
        if command is not None:
            q, dq, kp, kd, tau = command.q, command.dq, command.kp, command.kd, command.tau_ff
        elif damping:
            q, dq, kp, kd, tau = self._q, self._zeros, self._zeros, self._damp_kd, self._zeros
        else:  # limp: zero everything (position 0 at the motor)
            q, dq, kp, kd, tau = self._offset, self._zeros, self._zeros, self._zeros, self._zeros
        s, g = self._sign, self._gear
        return s * (q - self._offset) * g, s * dq * g, kp / (g * g), kd / (g * g), s * tau / g

    def _exchange(self, limp: bool, damping: bool = False, command: JointCommand | None = None, timeout: float | None = None) -> None:
        cached = command is not None and command is self._encoded[0]
        motor = None if cached and not self._has_serial else self._motor_side(limp, damping, command)
        frames = self._encoded[1] if cached else b""
        if not cached and len(self._mit_index) and motor is not None:
            mi = self._mit_index
            frames = mit.encode_commands(self._mit_ranges, *(a[mi] for a in motor)).tobytes()  # type: ignore[arg-type]
            self._encoded = (command, frames)
        for driver in self._drivers.values():
            if isinstance(driver, MitBusDriver):
                driver.send_frames(frames)
            elif motor is not None:
                idx = driver.joint_index
                mq, mdq, mkp, mkd, mtau = (a[idx] for a in motor)
                driver.send_arrays(mq, mdq, mkp, mkd, mtau, enabled=not limp)
        deadline = time.monotonic() + (timeout if timeout is not None else self.cfg.safety.cycle_timeout)
        serial_drivers = [d for d in self._drivers.values() if isinstance(d, Rs485BusDriver)]
        while serial_drivers:  # RS-485 ports in parallel: one frame out on each, then each reply
            serial_drivers = [d for d in serial_drivers if d.write_next(deadline)]
            for driver in serial_drivers:
                driver.read_pending()
        deadline = self._replies_deadline(deadline)
        for driver in self._drivers.values():
            if isinstance(driver, MitBusDriver):
                driver.collect(deadline)
        self._replies.publish(self.store, self.stamp_clock())
        if self.imu is not None:
            self.imu.poll()

    def _replies_deadline(self, deadline: float) -> float:
        """Until when CAN replies are waited for: `deadline`; on simulated hardware, now, once every reply that will come came."""
        if self._await_replies is None:
            return deadline
        self._await_replies()
        return time.monotonic()

    def _update_state(self) -> None:
        st = self.store
        if self._all_replied or not np.isnan(st.stamp).any():  # stamps never go back to NaN
            self._all_replied = True
            np.multiply(st.position, self._q_scale, out=self._q)
            self._q += self._offset
            np.multiply(st.velocity, self._q_scale, out=self._dq)
            np.multiply(st.torque, self._tau_scale, out=self._tau)
            return
        valid = ~np.isnan(st.stamp)
        self._q[valid] = st.position[valid] * self._q_scale[valid] + self._offset[valid]
        self._dq[valid] = st.velocity[valid] * self._q_scale[valid]
        self._tau[valid] = st.torque[valid] * self._tau_scale[valid]

    def _check_feedback(self) -> list[str]:
        now = self.stamp_clock()
        safety = self.cfg.safety
        st = self.store
        faults: list[str] = []
        # The common case costs four reductions; NaN (never replied) fails `>=` and is looked at.
        if (
            not st.stamp.min() >= now - safety.reply_timeout
            or st.missed.max() >= safety.max_missed_replies
            or st.faulted.any()
            or (st.temperature > safety.max_temperature).any()
        ):
            faults = self._feedback_faults(now)
        faults += [d.bus_fault for d in self._drivers.values() if d.bus_fault]
        if self.imu is not None and self.cfg.imu is not None:
            if self.imu.port_fault:
                faults.append(self.imu.port_fault)
            elif self.imu.age(now) > self.cfg.imu.timeout:
                age = self.imu.age(now)
                faults.append(f"IMU stale ({'no frame yet' if math.isinf(age) else f'last frame {1e3 * age:.0f} ms ago'})")
        return faults

    def _feedback_faults(self, now: float) -> list[str]:
        """Spell out which joints are wrong and why."""
        safety = self.cfg.safety
        st = self.store
        # NaN (never replied, no temperature) compares False: `~(age <= limit)` counts it as stale.
        stale = ~(now - st.stamp <= safety.reply_timeout)
        suspect = stale | (st.missed >= safety.max_missed_replies) | st.faulted | (st.temperature > safety.max_temperature)
        bad = [int(i) for i in np.flatnonzero(suspect)]
        fbs = [self.feedback(self._names[i]) for i in bad]
        return feedback_faults(
            tuple(self._names[i] for i in bad),
            [f.stamp for f in fbs],
            [f.missed for f in fbs],
            [(f.faulted, f.error) for f in fbs],
            [f.temperature for f in fbs],
            now,
            safety,
        )

    # -- reporting -------------------------------------------------------------------
    def counters(self) -> BusCounters:
        total = BusCounters()
        total.add(self._closed_counters)
        for driver in self._drivers.values():
            total.add(driver.counters)
        if self.imu is not None:
            total.crc_errors += self.imu.counters.crc_errors
            total.bad_frames += self.imu.counters.bad_frames
        return total

    def feedback(self, name: str) -> MotorFeedback:
        return self.store.feedback(self._names.index(name))

    # -- shutdown --------------------------------------------------------------------
    def _shutdown(self) -> None:
        try:
            self.deactivate()
        except (BusError, OSError) as exc:  # the bus may already be gone; damping was attempted first
            log.error("deactivate during close failed: %s", exc)
        finally:
            self._close_buses()
            self.state = Lifecycle.CLOSED

    def _close_buses(self) -> None:
        self._closed_counters = self.counters()
        for driver in self._drivers.values():
            driver.close()
        if self.imu is not None:
            self.imu.close()
        self._drivers, self._slot_of, self.imu = {}, {}, None
