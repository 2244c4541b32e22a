"""Firmware emulators: MIT-mode motors on a CAN bus, GO-M8010-style motors on RS-485, a serial IMU.

Like real motor firmware, an emulator works in two places. Its receive side answers
each frame at once with the status sampled at the last control tick and files the
command away: on a thread of its own (simulated hardware in the host's process), or
from the bus robot process's loop (`g1ctl robot --buses`, `sim/bus_robot.py`), CAN as
an slcan adapter on a pseudo-terminal (`SlcanMitEmulator`). `tick()` (called once per
physics step) is the control loop: it decodes the newest command exactly as the firmware
would (quantization included), runs the watchdog and the thermal model, pushes the PD law
into the plant and samples the status the next replies carry.
"""

from __future__ import annotations

import array
import fcntl
import logging
import os
import select
import termios
import threading
import time
from typing import Literal

import can
from can.interfaces.virtual import VirtualBus

from hw.emulation.faults import FaultPlan
from hw.emulation.imu_model import ImuModel
from hw.emulation.motor import EmulatedMotor
from hw.emulation.plant import Plant
from hw.protocols import imu as imu_frame
from hw.protocols import mit, slcan
from hw.protocols import unitree_rs485 as rs485
from hw.protocols.crc import FrameError

CAN_ERR_PROT = 0x08  # SocketCAN error classes (linux/can/error.h)
CAN_ERR_BUSOFF = 0x40
CUBEMARS_OVER_TEMPERATURE = 1
DAMIAO_COIL_OVER_TEMPERATURE = 0xC
RS485_OVERHEAT = 1
PTY_DELIVERY_TIMEOUT_S = 0.5  # how long an IMU frame may take to reach its reader through a pseudo-terminal
PTY_DELIVERY_POLL_S = 5e-5

log = logging.getLogger(__name__)


class _Emulator:
    """The firmware of the motors on one bus, answering frames until `close()`: on a background thread of its own
    (`start`), or from the bus robot process's loop (`start_served`, then `serve()` whenever its port is readable). A
    thread that dies keeps why in `error` (and the log has the traceback): `SimulatedHardware.step()` raises it into
    the run. A reply a fault delays waits on the thread; served from a loop it is held until due (`flush_due`)."""

    def __init__(self, name: str, plant: Plant, faults: FaultPlan | None) -> None:
        self.name = name
        self.plant = plant
        self.faults = faults or FaultPlan()
        self.frames_in = 0
        self.frames_out = 0
        self.error: Exception | None = None
        self._running = True
        self._served = False  # answered from a loop (the robot process), not a thread
        self._held: list[tuple[float, bytes]] = []  # served: delayed replies (wall-clock due time, bytes) in order
        self._thread = threading.Thread(target=self._run, name=f"emulator-{name}", daemon=True)

    def start(self) -> None:
        self.sample()  # a first status before answering anything
        self._thread.start()

    def start_served(self) -> None:
        """Answer from a loop that calls `serve()` when the port is readable and `flush_due()` now and then."""
        self.sample()
        self._served = True

    def serve(self) -> None:
        """Read what has arrived at the port and answer it (served from a loop)."""
        raise NotImplementedError

    def _write(self, data: bytes) -> None:
        raise NotImplementedError

    def _reply(self, data: bytes, delay: float) -> None:
        """Send `data` now, or after a fault's `delay` (on the thread: waiting; served: held until due)."""
        if not delay:
            self._write(data)
        elif self._served:
            self._held.append((time.monotonic() + delay, data))
        else:
            time.sleep(delay)
            self._write(data)

    def flush_due(self) -> None:
        """Served: send the held replies whose delay has passed."""
        now = time.monotonic()
        while self._held and self._held[0][0] <= now:
            self._write(self._held.pop(0)[1])

    def next_due(self) -> float | None:
        """Served: when the next held reply is due (None: none is held)."""
        return self._held[0][0] if self._held else None

    def _run(self) -> None:
        try:
            self._serve()
        except Exception as exc:  # the thread ends here: keep the cause for the run to raise
            self.error = exc
            log.error("firmware emulator '%s' died: %s: %s", self.name, type(exc).__name__, exc, exc_info=exc)

    def _serve(self) -> None:
        raise NotImplementedError

    def tick(self) -> None:
        """Control step, before physics: apply the newest commands."""
        raise NotImplementedError

    def sample(self) -> None:
        """After physics: sample the status every reply until the next sample carries."""
        with self.plant.lock:
            for motor_id in self.motor_ids():
                self._sample(motor_id)

    def motor_ids(self) -> list[int]:
        raise NotImplementedError

    def _sample(self, motor_id: int) -> None:
        raise NotImplementedError

    def close(self) -> None:
        self._running = False
        if self._thread.is_alive():
            self._thread.join(timeout=1.0)


MitAnswer = Literal["reply", "bus-off", "corrupted"]


class MitBusEmulator(_Emulator):
    """MIT-mode motors on one CAN bus; each answers only frames to its own id. On a python-can `virtual` channel
    (`bus`, answered on a thread) or, in the bus robot process, slcan lines on a pseudo-terminal (`SlcanMitEmulator`).

    `wait_answered()` returns once every frame on the virtual bus has been answered, or its reply dropped: the host of a
    simulated run then takes the replies without waiting on the wall clock, which a loaded machine would stretch
    past the cycle's timeout. Replies delayed by a fault are not waited for: on the simulated clock they come late.
    """

    def __init__(
        self,
        name: str,
        bus: VirtualBus | None,
        motors: dict[int, tuple[EmulatedMotor, mit.MitRanges, mit.ReplyVariant]],
        plant: Plant,
        faults: FaultPlan | None = None,
    ) -> None:
        super().__init__(name, plant, faults)
        self._bus = bus
        self.motors = motors
        self._pending: dict[int, bytes] = {}  # newest command frame per motor, decoded at the next tick
        # Per motor, the status sampled at the last tick: position, velocity, torque, temperature, error code, Damiao state.
        self._status: dict[int, tuple[float, float, float, float, int, int]] = {}
        self._bus_off_sent = False

    @property
    def bus(self) -> VirtualBus:
        if self._bus is None:
            raise TypeError(f"the emulator of bus '{self.name}' has no virtual CAN channel: it is served over slcan")
        return self._bus

    def wait_answered(self, timeout: float) -> None:
        """Until every frame sent to the motors was answered or dropped (at most `timeout` s: a hung emulator).
        Served over slcan (another process's host) there is nothing to wait on here."""
        if self.faults.delay_reply_s or self._bus is None:
            return
        inbox = self.bus.queue
        with inbox.all_tasks_done:  # what `Queue.join()` waits on, with a timeout
            inbox.all_tasks_done.wait_for(lambda: not inbox.unfinished_tasks or not self._thread.is_alive(), timeout)

    def _serve(self) -> None:
        while self._running:
            msg = self.bus.recv(timeout=0.05)
            if msg is None:
                continue
            try:
                self._answer(msg)
            finally:
                self.bus.queue.task_done()  # answered, dropped or ignored: what `wait_answered` waits for

    def _answer(self, msg: can.Message) -> None:
        if msg.is_error_frame:
            return
        answer = self.respond(msg.arbitration_id, bytes(msg.data))
        if answer is None:
            return
        if self.faults.delay_reply_s and answer != "bus-off":
            time.sleep(self.faults.delay_reply_s)
        if answer == "reply":
            self.bus.send(can.Message(arbitration_id=msg.arbitration_id, data=self.status_frame(msg.arbitration_id), is_extended_id=False))
        else:  # receivers see an error frame: bus-off, or a reply whose CRC failed
            error = CAN_ERR_BUSOFF if answer == "bus-off" else CAN_ERR_PROT
            self.bus.send(can.Message(is_error_frame=True, arbitration_id=error, data=bytes(8), is_extended_id=True))

    def respond(self, motor_id: int, data: bytes) -> MitAnswer | None:
        """What the firmware makes of one frame to `motor_id`, whatever carried it: the command filed (or a special frame
        acted on), then its answer: the status reply, an error (bus-off, once; a reply corrupted on the wire, which fails
        every receiver's CRC) or none (another motor's id, a malformed frame, a silent bus, a dropped reply)."""
        faults = self.faults
        if motor_id not in self.motors:
            return None
        self.frames_in += 1
        if faults.bus_off:
            if not self._bus_off_sent:
                self._bus_off_sent = True
                return "bus-off"
            return None
        if len(data) != 8:
            return None  # the firmware ignores malformed frames
        if data[:7] == b"\xff" * 7:
            self._special(motor_id, data)
        else:
            self._pending[motor_id] = data
        if faults.drop_reply_prob and faults.drop():
            return None
        if faults.corrupt_prob and faults.corrupt(b"x") != b"x":
            return "corrupted"
        self.frames_out += 1
        return "reply"

    def _special(self, motor_id: int, data: bytes) -> None:
        motor = self.motors[motor_id][0]
        kind = mit.SPECIAL_FRAMES.get(data)
        with self.plant.lock:
            if kind == "enter":
                motor.enabled, motor.error_code = True, 0  # re-entering motor mode clears a latched error
            elif kind == "exit":
                motor.enabled = False
                self._pending.pop(motor_id, None)
            elif kind == "zero":
                motor.set_zero(self.plant)
            self._sample(motor_id)

    def tick(self) -> None:
        with self.plant.lock:
            for motor_id, (motor, ranges, variant) in self.motors.items():
                data = self._pending.pop(motor_id, None)
                command = None if data is None else mit.decode_command(ranges, data)  # quantized as the firmware sees it
                code = DAMIAO_COIL_OVER_TEMPERATURE if variant == "damiao" else CUBEMARS_OVER_TEMPERATURE
                self._inject(motor_id, motor, code)
                motor.apply(self.plant, command, code, motor_id in self.faults.stuck)

    def motor_ids(self) -> list[int]:
        return list(self.motors)

    def _sample(self, motor_id: int) -> None:
        motor = self.motors[motor_id][0]
        position, velocity, torque = motor.reading(self.plant)
        state = motor.error_code or (1 if motor.enabled else 0)  # a Damiao reply's state nibble
        self._status[motor_id] = (position, velocity, torque, motor.temperature, motor.error_code, state)

    def status_frame(self, motor_id: int) -> bytes:
        """The reply carrying the status sampled at the last tick, encoded when asked for: the motors are sampled every
        physics step, and a bus slower than the physics asks for fewer replies than that."""
        _, ranges, variant = self.motors[motor_id]
        position, velocity, torque, temperature, error_code, state = self._status[motor_id]
        if variant == "damiao":
            return mit.encode_reply(ranges, variant, motor_id, position, velocity, torque, temperature, temperature, state)
        return mit.encode_reply(ranges, variant, motor_id, position, velocity, torque, temperature, error_code=error_code)

    def _inject(self, motor_id: int, motor: EmulatedMotor, over_temp_code: int) -> None:
        if motor_id in self.faults.error_codes:
            motor.error_code = self.faults.error_codes.pop(motor_id)
        if motor_id in self.faults.over_temperature:
            motor.temperature = max(motor.temperature, 120.0)
            motor.error_code = motor.error_code or over_temp_code

    def close(self) -> None:
        super().close()
        if self._bus is not None:
            self._bus.shutdown()


class SlcanMitEmulator(MitBusEmulator):
    """The MIT motors of one CAN bus behind a USB-CAN adapter that speaks slcan: the bus robot process holds the
    adapter's end of a pseudo-terminal (`fd`) and serves it from its loop. A batch of frames that arrived together
    is answered in one write, as an adapter forwards what the bus carried since its last USB transfer.

    slcan carries no error frames: bus-off is the adapter's status line with the bus-error flag, sent once; a reply
    corrupted on the wire never reaches the adapter's host (its controller drops a frame that fails the CRC).
    """

    def __init__(
        self, name: str, fd: int, motors: dict[int, tuple[EmulatedMotor, mit.MitRanges, mit.ReplyVariant]], plant: Plant,
        faults: FaultPlan | None = None,
    ) -> None:  # fmt: skip
        super().__init__(name, None, motors, plant, faults)
        self.fd = fd
        self.bad_lines = 0
        self._rest = b""
        os.set_blocking(fd, False)

    def serve(self) -> None:
        try:
            data = os.read(self.fd, 65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            return  # EIO: the host has not opened its end, or closed it; it may open it again
        lines, self._rest = slcan.split_lines(self._rest + data)
        out: list[bytes] = []
        delay = self.faults.delay_reply_s
        for line in lines:
            head = line[:1]
            if head in (b"t", b"T"):
                try:
                    frame = slcan.decode_frame(line)
                except FrameError:
                    self.bad_lines += 1
                    out.append(slcan.BELL)
                    continue
                answer = self.respond(frame.arbitration_id, frame.data)
                if answer == "reply":
                    reply = slcan.encode_frame(frame.arbitration_id, self.status_frame(frame.arbitration_id))
                    if delay:
                        self._reply(reply, delay)
                    else:
                        out.append(reply)
                elif answer == "bus-off":
                    out.append(slcan.encode_status(slcan.STATUS_BUS_ERROR))
            elif head in (b"C", b"O", b"L", b"S"):
                out.append(slcan.CR)  # the adapter's "done": close, open, listen, bitrate
            elif line:
                self.bad_lines += 1
                out.append(slcan.BELL)
        if out:
            self._write(b"".join(out))

    def _write(self, data: bytes) -> None:
        try:
            os.write(self.fd, data)
        except (BlockingIOError, OSError):
            return  # nobody reads: the adapter's buffer overflows and the frames are lost, as on the wire

    def close(self) -> None:
        self._running = False


class Rs485PortEmulator(_Emulator):
    """GO-M8010-style motors sharing one RS-485 port (the far end of a pseudo-terminal)."""

    def __init__(self, name: str, fd: int, motors: dict[int, EmulatedMotor], plant: Plant, faults: FaultPlan | None = None) -> None:
        super().__init__(name, plant, faults)
        self.fd = fd
        self.motors = motors
        self.crc_errors = 0
        self._splitter = rs485.FrameSplitter(rs485.COMMAND_HEADER, rs485.COMMAND_SIZE)
        self._pending: dict[int, rs485.CommandFrame] = {}
        self._mode: dict[int, int] = dict.fromkeys(motors, rs485.MODE_BRAKE)
        self._status: dict[int, tuple[int, float, float, float, int, int]] = {}  # sampled at the last tick: encode_reply's values

    def _serve(self) -> None:
        while self._running:
            ready, _, _ = select.select([self.fd], [], [], 0.05)
            if not ready:
                continue
            try:
                data = os.read(self.fd, 4096)
            except OSError:
                return  # the host side closed
            for frame in self._splitter.feed(data):
                self._answer(frame)

    def serve(self) -> None:
        try:
            data = os.read(self.fd, 4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            return  # EIO: the host has not opened its end, or closed it; it may open it again
        for frame in self._splitter.feed(data):
            self._answer(frame)

    def _write(self, data: bytes) -> None:
        try:
            os.write(self.fd, data)
            self.frames_out += 1
        except OSError:
            return

    def _answer(self, frame: bytes) -> None:
        try:
            cmd = rs485.decode_command(frame)
        except rs485.FrameError:
            self.crc_errors += 1  # the firmware drops a frame that fails its CRC
            return
        if cmd.motor_id not in self.motors:
            return  # another motor's id, or broadcast: no reply
        self.frames_in += 1
        self._pending[cmd.motor_id] = cmd
        if self._mode[cmd.motor_id] != cmd.mode:
            with self.plant.lock:
                self._mode[cmd.motor_id] = cmd.mode
                self._sample(cmd.motor_id)
        if self.faults.drop_reply_prob and self.faults.drop():
            return
        self._reply(self.faults.corrupt(self.status_frame(cmd.motor_id)), self.faults.delay_reply_s)

    def tick(self) -> None:
        with self.plant.lock:
            for motor_id, motor in self.motors.items():
                cmd = self._pending.pop(motor_id, None)
                if motor_id in self.faults.error_codes:
                    motor.error_code = self.faults.error_codes.pop(motor_id)
                if motor_id in self.faults.over_temperature:
                    motor.temperature, motor.error_code = max(motor.temperature, 120.0), motor.error_code or RS485_OVERHEAT
                command = None
                if cmd is not None and cmd.mode == rs485.MODE_BRAKE:
                    motor.enabled, motor.error_code = False, 0  # brake clears a latched error
                elif cmd is not None:
                    motor.enabled = True
                    command = cmd.command
                motor.apply(self.plant, command, RS485_OVERHEAT, motor_id in self.faults.stuck)

    def motor_ids(self) -> list[int]:
        return list(self.motors)

    def _sample(self, motor_id: int) -> None:
        motor = self.motors[motor_id]
        position, velocity, torque = motor.reading(self.plant)
        self._status[motor_id] = (self._mode[motor_id], torque, velocity, position, round(motor.temperature), motor.error_code)

    def status_frame(self, motor_id: int) -> bytes:
        """The reply carrying the status sampled at the last tick, encoded when asked for (see `MitBusEmulator`)."""
        return rs485.encode_reply(motor_id, *self._status[motor_id])


class ImuEmulator:
    """Writes one IMU frame per `emit()` to the far end of a pseudo-terminal: the plant's reading as `model` measures it
    (None: as it is), with the bias of a fault plan's `gyro_bias`/`accel_bias` once in force.

    `reader_fd` (the host's end): `emit()` returns once a frame's bytes can be read there. A pseudo-terminal hands
    written bytes over from a kernel worker, which a loaded machine can hold back for tens of milliseconds: on the
    simulated clock, which does not wait, that would read as an IMU gone stale; on a UART the frame is on the wire.
    """

    def __init__(
        self, fd: int, plant: Plant, faults: FaultPlan | None = None, reader_fd: int | None = None, model: ImuModel | None = None
    ) -> None:
        self.fd = fd
        self.plant = plant
        self.faults = faults or FaultPlan()
        self.model = model
        self.reader_fd = reader_fd
        self.sequence = 0
        self.overflows = 0
        os.set_blocking(fd, False)

    def emit(self) -> None:
        if self.faults.silent:
            return
        with self.plant.lock:
            reading, now = self.plant.imu_reading(), self.plant.time()
        if self.model is not None:
            reading = self.model.measure(reading, now, self.faults.imu_bias)
        quat, gyro, acc = reading
        sample = imu_frame.ImuSample(self.sequence, quat, gyro, acc)  # type: ignore[arg-type]
        self.sequence = (self.sequence + 1) & 0xFFFF
        try:
            written = os.write(self.fd, self.faults.corrupt(imu_frame.encode_imu(sample)))
        except BlockingIOError:
            self.overflows += 1  # nobody reads: the frame is lost, as on a real UART
            return
        if self.reader_fd is not None:
            _wait_readable(self.reader_fd, written)


def _wait_readable(fd: int, count: int) -> None:
    """Until `count` bytes wait to be read at `fd`, for at most PTY_DELIVERY_TIMEOUT_S (then its reader finds them missing)."""
    waiting = array.array("i", [0])
    deadline = time.monotonic() + PTY_DELIVERY_TIMEOUT_S
    while fcntl.ioctl(fd, termios.FIONREAD, waiting) == 0 and waiting[0] < count and time.monotonic() < deadline:
        time.sleep(PTY_DELIVERY_POLL_S)
