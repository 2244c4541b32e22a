"""Motor bus drivers: encode commands, exchange frames on one bus, decode and count replies.

Everything here is on the motor side (rotor units, motor ids); the robot layer converts
to joints. A driver never raises on a bad frame: it counts it, and the safety layer
decides. Bus-level failures (bus-off, a port that vanished) are counted and reported
through `bus_fault`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import can
import serial

from hw.protocols import mit
from hw.protocols import unitree_rs485 as rs485


@dataclass(frozen=True)
class MotorCommand:
    """Motor-side PD command (rotor units)."""

    q: float
    dq: float
    kp: float
    kd: float
    tau: float


@dataclass
class MotorFeedback:
    """Newest reply of one motor (motor side); `stamp` is None until the first reply."""

    position: float = 0.0
    velocity: float = 0.0
    torque: float = 0.0
    temperature: float | None = None
    error_code: int = 0
    error: str = "ok"
    faulted: bool = False
    stamp: float | None = None
    missed: int = 0  # consecutive exchanges without a reply


@dataclass
class BusCounters:
    frames_sent: int = 0
    frames_received: int = 0
    dropped: int = 0  # expected replies that did not come
    crc_errors: int = 0
    bad_frames: int = 0  # wrong length or header
    unknown_ids: int = 0
    error_frames: int = 0
    send_errors: int = 0

    def add(self, other: BusCounters) -> None:
        for key, value in vars(other).items():
            setattr(self, key, getattr(self, key) + value)


@dataclass(frozen=True)
class MitMotor:
    motor_id: int
    ranges: mit.MitRanges
    reply: mit.ReplyVariant


@dataclass
class _Driver:
    name: str
    motor_ids: tuple[int, ...]
    stamp_clock: object = time.monotonic
    counters: BusCounters = field(default_factory=BusCounters)
    feedback: dict[int, MotorFeedback] = field(default_factory=dict)
    bus_fault: str | None = None

    def __post_init__(self) -> None:
        self.feedback = {i: MotorFeedback() for i in self.motor_ids}

    def _now(self) -> float:
        return float(self.stamp_clock())  # type: ignore[operator]


class MitBusDriver(_Driver):
    """MIT-mode motors on one CAN bus. Commands go to arbitration id = motor id."""

    def __init__(self, name: str, bus: can.BusABC, motors: list[MitMotor], stamp_clock: object = time.monotonic) -> None:
        super().__init__(name, tuple(m.motor_id for m in motors), stamp_clock)
        self.bus = bus
        self.motors = {m.motor_id: m for m in motors}
        self._awaiting: set[int] = set()
        # Damiao replies carry the id in the low nibble of byte 0, the others in the whole byte.
        self._id_mask = 0x0F if {m.reply for m in motors} == {"damiao"} else 0xFF

    def send_special(self, frame: bytes, motor_ids: tuple[int, ...] | None = None) -> None:
        """Enter/exit motor mode or set zero; each motor answers with a status reply."""
        for motor_id in motor_ids or self.motor_ids:
            self._send(motor_id, frame)

    def send_commands(self, commands: dict[int, MotorCommand]) -> None:
        for motor_id, c in commands.items():
            self._send(motor_id, mit.encode_command(self.motors[motor_id].ranges, c.q, c.dq, c.kp, c.kd, c.tau))

    def _send(self, motor_id: int, data: bytes) -> None:
        try:
            self.bus.send(can.Message(arbitration_id=motor_id, data=data, is_extended_id=False), timeout=0.001)
        except can.CanError as exc:
            self.counters.send_errors += 1
            self.bus_fault = f"CAN bus '{self.name}' send failed: {exc}"
            return
        self.counters.frames_sent += 1
        self._awaiting.add(motor_id)

    def collect(self, deadline: float) -> None:
        """Read replies until every awaited motor answered or the wall-clock `deadline` passes."""
        while self._awaiting:
            remaining = deadline - time.monotonic()
            msg = self.bus.recv(timeout=max(remaining, 0.0))
            if msg is None:
                break
            self._handle(msg)
        while (msg := self.bus.recv(timeout=0.0)) is not None:  # late frames already queued
            self._handle(msg)
        for motor_id in self._awaiting:
            self.counters.dropped += 1
            self.feedback[motor_id].missed += 1
        self._awaiting.clear()

    def collect_now(self, timeout: float) -> None:
        self.collect(time.monotonic() + timeout)

    def _handle(self, msg: can.Message) -> None:
        if msg.is_error_frame:
            self.counters.error_frames += 1
            self.bus_fault = f"CAN bus '{self.name}' reported an error frame (bus-off or wiring fault)"
            return
        data = bytes(msg.data)
        if len(data) == 8 and msg.arbitration_id in self.motors and data[:7] == b"\xff" * 7:
            return  # another host's special frame echoed on the bus
        if len(data) not in (6, 8):
            self.counters.bad_frames += 1
            return
        motor_id = data[0] & self._id_mask
        motor = self.motors.get(motor_id)
        if motor is None:
            self.counters.unknown_ids += 1
            return
        try:
            reply = mit.decode_reply(motor.ranges, motor.reply, data)
        except ValueError:
            self.counters.bad_frames += 1
            return
        self.counters.frames_received += 1
        fb = self.feedback[motor_id]
        fb.position, fb.velocity, fb.torque = reply.position, reply.velocity, reply.torque
        fb.temperature, fb.error_code, fb.error, fb.faulted = reply.temperature, reply.error_code, reply.error, reply.faulted
        fb.stamp, fb.missed = self._now(), 0
        self._awaiting.discard(motor_id)

    def close(self) -> None:
        self.bus.shutdown()


class Rs485BusDriver(_Driver):
    """GO-M8010-style motors on one half-duplex RS-485 port: one command, one reply, in turn."""

    def __init__(self, name: str, port: serial.SerialBase, motor_ids: list[int], stamp_clock: object = time.monotonic) -> None:
        super().__init__(name, tuple(motor_ids), stamp_clock)
        self.port = port
        self._splitter = rs485.FrameSplitter(rs485.REPLY_HEADER, rs485.REPLY_SIZE)
        self._queue: list[tuple[int, bytes]] = []

    def send_commands(self, commands: dict[int, MotorCommand], mode: int = rs485.MODE_FOC) -> None:
        """Queue the frames; the bus is half-duplex, so each goes out when the previous reply is in."""
        self._queue = [(i, rs485.encode_command(i, mode, c.tau, c.dq, c.q, c.kp, c.kd)) for i, c in commands.items()]
        self._pending: tuple[int, float] | None = None

    def write_next(self, deadline: float) -> bool:
        """Send the next queued frame; False when nothing is left."""
        if not self._queue:
            return False
        motor_id, frame = self._queue.pop(0)
        if not self._write(frame):
            self._queue = []
            return False
        share = (deadline - time.monotonic()) / (len(self._queue) + 1)
        self._pending = (motor_id, time.monotonic() + share)
        return True

    def read_pending(self) -> None:
        """Wait for the reply to the frame just sent (until its share of the deadline)."""
        if self._pending is None:
            return
        motor_id, deadline = self._pending
        self._pending = None
        if not self._await_reply(motor_id, deadline):
            self.counters.dropped += 1
            self.feedback[motor_id].missed += 1

    def collect(self, deadline: float) -> None:
        while self.write_next(deadline):
            self.read_pending()

    def _write(self, frame: bytes) -> bool:
        try:
            self.port.write(frame)
        except (serial.SerialException, OSError) as exc:
            self.counters.send_errors += 1
            self.bus_fault = f"serial port '{self.name}' write failed: {exc}"
            return False
        self.counters.frames_sent += 1
        return True

    def _await_reply(self, motor_id: int, deadline: float) -> bool:
        while True:
            remaining = deadline - time.monotonic()
            self.port.timeout = max(remaining, 0.0)
            try:
                data = self.port.read(max(self.port.in_waiting, 1) if remaining > 0 else self.port.in_waiting)
            except (serial.SerialException, OSError) as exc:
                self.bus_fault = f"serial port '{self.name}' read failed: {exc}"
                return False
            got = False
            for frame in self._splitter.feed(data):
                got |= self._handle(frame) == motor_id
            if got:
                return True
            if remaining <= 0:
                return False

    def _handle(self, frame: bytes) -> int | None:
        try:
            reply = rs485.decode_reply(frame)
        except rs485.FrameError as exc:
            if "CRC" in str(exc):
                self.counters.crc_errors += 1
            else:
                self.counters.bad_frames += 1
            return None
        fb = self.feedback.get(reply.motor_id)
        if fb is None:
            self.counters.unknown_ids += 1
            return None
        self.counters.frames_received += 1
        fb.position, fb.velocity, fb.torque = reply.position, reply.speed, reply.torque
        fb.temperature, fb.error_code, fb.error = float(reply.temperature), reply.error_code, reply.error
        fb.faulted = reply.error_code != 0
        fb.stamp, fb.missed = self._now(), 0
        return reply.motor_id

    def close(self) -> None:
        self.port.close()
