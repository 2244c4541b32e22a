"""Motor bus drivers: encode commands, exchange frames on one bus, decode and count replies.

Everything here is on the motor side (rotor units, motor ids); the robot layer converts
to joints. Commands are encoded for every motor at once, and a batch that did not change
is sent again as it is; replies land in a shared feedback store. A driver never raises on
a bad frame: it counts it, and the safety layer decides. A reply that misses its cycle's
deadline is taken before the next send as late, so it cannot answer the next command.
Bus-level failures (an error frame, a port that vanished) are reported through `bus_fault`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import can
import numpy as np
import serial

from hw.feedback import FeedbackStore, MitReplyBank
from hw.protocols import mit
from hw.protocols import unitree_rs485 as rs485
from hw.slcan import SlcanBus
from hw.transport import read_waiting, read_within

CAN_ERR_CRTL = 0x04  # SocketCAN error classes (linux/can/error.h): controller problems
CAN_ERR_BUSOFF = 0x40


@dataclass
class BusCounters:
    frames_sent: int = 0
    frames_received: int = 0
    dropped: int = 0  # expected replies that did not come before the cycle's deadline
    late_replies: int = 0  # of those, the ones that came afterwards (their values are used, their stamps are not)
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


class BusDriver:
    """What both protocols share: the motors of one bus, where their feedback goes, counters."""

    def __init__(
        self, name: str, motor_ids: list[int], joint_index: list[int], store: FeedbackStore, stamp_clock: Callable[[], float]
    ) -> None:
        self.name = name
        self.motor_ids = tuple(motor_ids)
        self.joint_index = np.array(joint_index, dtype=np.int64)
        self.slot = dict(zip(motor_ids, joint_index, strict=True))  # motor id -> robot joint index
        self.store = store
        self.stamp_clock = stamp_clock
        self.counters = BusCounters()
        self.bus_fault: str | None = None

    def close(self) -> None:
        raise NotImplementedError


class MitBusDriver(BusDriver):
    """MIT-mode motors on one CAN bus. Commands go to arbitration id = motor id; replies are
    handed undecoded to the robot's `MitReplyBank`, rows `first_row` onwards in motor order."""

    def __init__(
        self,
        name: str,
        bus: can.BusABC,
        motors: list[MitMotor],
        joint_index: list[int],
        store: FeedbackStore,
        bank: MitReplyBank,
        first_row: int,
        stamp_clock: Callable[[], float] = time.monotonic,
    ) -> None:
        super().__init__(name, [m.motor_id for m in motors], joint_index, store, stamp_clock)
        self.bus = bus
        self.motors = motors
        self.bank = bank
        self._first_row = first_row  # where this bus's frames start in a batch of command frames
        # (first reply byte, reply length) of a healthy reply -> (bank row, robot joint index)
        self._accept = {
            (m.motor_id, 6 if m.reply == "basic" else 8): (first_row + k, j)
            for k, (m, j) in enumerate(zip(motors, joint_index, strict=True))
        }
        # Damiao replies carry the id in the low nibble of byte 0, the others in the whole byte.
        self._id_mask = 0x0F if {m.reply for m in motors} == {"damiao"} else 0xFF
        self._messages = [can.Message(arbitration_id=i, data=bytearray(8), is_extended_id=False) for i in self.motor_ids]
        self._loaded: bytes | None = None  # the batch whose frames the messages hold
        self._awaiting: set[int] = set()
        self._joints = [int(j) for j in joint_index]

    def send_special(self, frame: bytes, motor_ids: tuple[int, ...] | None = None) -> None:
        """Enter/exit motor mode or set zero; each motor answers with a status reply."""
        self._loaded = None
        self._take_queued()
        for motor_id in motor_ids or self.motor_ids:
            k = self.motor_ids.index(motor_id)
            self._messages[k].data = bytearray(frame)
            self._send(k)

    def send_frames(self, batch: bytes) -> None:
        """Send this bus's 8-byte command frames out of `batch` (every MIT motor's frame, robot
        MIT order). An unchanged batch (the same object) is sent again without copying."""
        self._take_queued()
        send, sent = self.bus.send, 0
        if batch is not self._loaded:
            for k, msg in enumerate(self._messages, start=self._first_row):
                msg.data = bytearray(batch[8 * k : 8 * k + 8])
            self._loaded = batch
        try:
            if isinstance(self.bus, SlcanBus):  # one write for the whole batch: the adapter's serial link takes it at once
                self.bus.send_batch(self._messages)
                sent = len(self._messages)
            else:
                for msg in self._messages:
                    send(msg)
                    sent += 1
        except can.CanError as exc:
            self.counters.send_errors += 1
            self.bus_fault = f"CAN bus '{self.name}' send failed: {exc}"
        self.counters.frames_sent += sent
        self._awaiting.update(self._joints[:sent])

    def _send(self, k: int) -> None:
        try:
            self.bus.send(self._messages[k], timeout=0.001)
        except can.CanError as exc:
            self.counters.send_errors += 1
            self.bus_fault = f"CAN bus '{self.name}' send failed: {exc}"
            return
        self.counters.frames_sent += 1
        self._awaiting.add(self._joints[k])

    def collect(self, deadline: float) -> None:
        """File replies until every awaited motor answered or the wall-clock `deadline` passes."""
        awaiting = self._awaiting
        while awaiting:
            msg = self._recv(max(deadline - time.monotonic(), 0.0))
            if msg is None:
                break
            self._take(msg)
        if awaiting:  # the deadline passed: a reply that comes later is taken before the next send
            self.counters.dropped += len(awaiting)
            for j in awaiting:
                self.store.missed[j] += 1
            awaiting.clear()

    def _take_queued(self) -> None:
        """Before a send: take what arrived since the last collect (late replies, error frames).
        MIT replies carry no sequence number, so a late reply left queued would stand in for
        the next command's reply, and every cycle after would read the one before it."""
        while (msg := self._recv(0.0)) is not None:
            self._take_late(msg)

    def _recv(self, timeout: float) -> can.Message | None:
        """The next frame within `timeout`; None also when the interface failed (a USB adapter pulled, the far end of a
        pseudo-terminal gone): that is the bus's fault, which latches damping."""
        try:
            return self.bus.recv(timeout=timeout)
        except can.CanError as exc:
            self.bus_fault = f"CAN bus '{self.name}' receive failed: {exc}"
            return None

    def collect_now(self, timeout: float) -> None:
        self.collect(time.monotonic() + timeout)

    def _take(self, msg: can.Message) -> None:
        entry = self._accepted(msg)
        if entry is not None:
            self.bank.pending.append((entry[0], msg.data))
            self.counters.frames_received += 1
            self._awaiting.discard(entry[1])

    def _take_late(self, msg: can.Message) -> None:
        """A reply that missed its cycle's deadline: its values are the newest, but it answers no command of this cycle."""
        entry = self._accepted(msg)
        if entry is not None:
            self.bank.late.append((entry[0], msg.data))
            self.counters.frames_received += 1
            self.counters.late_replies += 1

    def _accepted(self, msg: can.Message) -> tuple[int, int] | None:
        """(bank row, joint index) of a healthy reply from one of this bus's motors; anything else is counted."""
        data = msg.data
        entry = None if msg.is_error_frame or not data else self._accept.get((data[0] & self._id_mask, len(data)))
        if entry is None:
            self._reject(msg)
        return entry

    def _reject(self, msg: can.Message) -> None:
        """Anything but a healthy reply from one of this bus's motors: say what it was."""
        if msg.is_error_frame:
            self.counters.error_frames += 1
            if msg.arbitration_id & (CAN_ERR_BUSOFF | CAN_ERR_CRTL):
                self.bus_fault = f"CAN bus '{self.name}' is bus-off or its controller failed (error class {msg.arbitration_id:#x})"
            return  # other classes (a frame that failed its CRC, ...) are counted, not fatal alone
        data = msg.data
        if len(data) == 8 and data[:7] == b"\xff\xff\xff\xff\xff\xff\xff":
            return  # another host's special frame on the bus
        if len(data) not in (6, 8):
            self.counters.bad_frames += 1
        elif any((data[0] & self._id_mask, size) in self._accept for size in (6, 8)):
            self.counters.bad_frames += 1  # a known motor, but the wrong reply length for its model
        else:
            self.counters.unknown_ids += 1

    def close(self) -> None:
        self.bus.shutdown()


class Rs485BusDriver(BusDriver):
    """GO-M8010-style motors on one half-duplex RS-485 port: one command, one reply, in turn."""

    def __init__(
        self,
        name: str,
        port: serial.SerialBase,
        motor_ids: list[int],
        joint_index: list[int],
        store: FeedbackStore,
        stamp_clock: Callable[[], float] = time.monotonic,
    ) -> None:
        super().__init__(name, motor_ids, joint_index, store, stamp_clock)
        self.port = port
        self._splitter = rs485.FrameSplitter(rs485.REPLY_HEADER, rs485.REPLY_SIZE)
        self._queue: list[tuple[int, bytes]] = []
        self._pending: tuple[int, float] | None = None

    def send_arrays(self, q: np.ndarray, dq: np.ndarray, kp: np.ndarray, kd: np.ndarray, tau: np.ndarray, enabled: bool) -> None:
        """Queue the frames; the bus is half-duplex, so each goes out when the previous reply is in."""
        self._take_queued()
        mode = rs485.MODE_FOC if enabled else rs485.MODE_BRAKE
        rows = zip(self.motor_ids, q.tolist(), dq.tolist(), kp.tolist(), kd.tolist(), tau.tolist(), strict=True)
        self._queue = [(i, rs485.encode_command(i, mode, t, v, p, a, b)) for i, p, v, a, b, t in rows]
        self._pending = None

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
            self.store.missed[self.slot[motor_id]] += 1

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
            try:
                data = read_within(self.port, max(remaining, 0.0))
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

    def _take_queued(self) -> None:
        """Before a cycle's first frame: what arrived since the last one is late (values, no stamp),
        so that it cannot pass for the reply to this cycle's command to the same motor."""
        try:
            data = read_waiting(self.port)
        except (serial.SerialException, OSError) as exc:
            self.bus_fault = f"serial port '{self.name}' read failed: {exc}"
            return
        for frame in self._splitter.feed(data):
            self._handle(frame, late=True)

    def _handle(self, frame: bytes, late: bool = False) -> int | None:
        try:
            reply = rs485.decode_reply(frame)
        except rs485.CrcError:
            self.counters.crc_errors += 1
            return None
        except rs485.FrameError:
            self.counters.bad_frames += 1
            return None
        j = self.slot.get(reply.motor_id)
        if j is None:
            self.counters.unknown_ids += 1
            return None
        self.counters.frames_received += 1
        st = self.store
        st.position[j], st.velocity[j], st.torque[j] = reply.position, reply.speed, reply.torque
        st.temperature[j], st.error_code[j], st.error[j] = reply.temperature, reply.error_code, reply.error
        st.faulted[j] = reply.error_code != 0
        if late:
            self.counters.late_replies += 1
            return None
        st.stamp[j], st.missed[j] = self.stamp_clock(), 0
        return reply.motor_id

    def close(self) -> None:
        self.port.close()
