"""Firmware emulators: MIT-mode motors on a CAN bus, GO-M8010-style motors on RS-485, a serial IMU.

Like real motor firmware, an emulator works in two places. Its receive thread answers
each frame at once with the status sampled at the last control tick and files the
command away; `tick()` (called once per physics step) is the control loop: it decodes
the newest command exactly as the firmware would (quantization included), runs the
watchdog and the thermal model, pushes the PD law into the plant and samples the status
the next replies carry.
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

import can
from can.interfaces.virtual import VirtualBus

from hw.emulation.faults import FaultPlan
from hw.emulation.imu_model import ImuModel
from hw.emulation.motor import EmulatedMotor
from hw.emulation.plant import Plant
from hw.protocols import imu as imu_frame
from hw.protocols import mit
from hw.protocols import unitree_rs485 as rs485

CAN_ERR_PROT = 0x08  # SocketCAN error classes (linux/can/error.h)
CAN_ERR_BUSOFF = 0x40
CUBEMARS_OVER_TEMPERATURE = 1
DAMIAO_COIL_OVER_TEMPERATURE = 0xC
RS485_OVERHEAT = 1
PTY_DELIVERY_TIMEOUT_S = 0.5  # how long an IMU frame may take to reach its reader through a pseudo-terminal
PTY_DELIVERY_POLL_S = 5e-5

log = logging.getLogger(__name__)


class _Emulator:
    """A background thread answering frames until `close()`. If it dies, `error` holds why
    (and the log has the traceback): `SimulatedHardware.step()` raises it into the run."""

    def __init__(self, name: str, plant: Plant, faults: FaultPlan | None) -> None:
        self.name = name
        self.plant = plant
        self.faults = faults or FaultPlan()
        self.frames_in = 0
        self.frames_out = 0
        self.error: Exception | None = None
        self._running = True
        self._thread = threading.Thread(target=self._run, name=f"emulator-{name}", daemon=True)

    def start(self) -> None:
        self.sample()  # a first status before answering anything
        self._thread.start()

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


class MitBusEmulator(_Emulator):
    """MIT-mode motors on one virtual CAN bus; each answers only frames to its own id.

    `wait_answered()` returns once every frame on the bus has been answered, or its reply dropped: the host of a
    simulated run then takes the replies without waiting on the wall clock, which a loaded machine would stretch
    past the cycle's timeout. Replies delayed by a fault are not waited for: on the simulated clock they come late.
    """

    def __init__(
        self,
        name: str,
        bus: VirtualBus,
        motors: dict[int, tuple[EmulatedMotor, mit.MitRanges, mit.ReplyVariant]],
        plant: Plant,
        faults: FaultPlan | None = None,
    ) -> None:
        super().__init__(name, plant, faults)
        self.bus = bus
        self.motors = motors
        self._pending: dict[int, bytes] = {}  # newest command frame per motor, decoded at the next tick
        self._status: dict[int, can.Message] = {}  # reply per motor, sampled at the last tick
        self._bus_off_sent = False

    def wait_answered(self, timeout: float) -> None:
        """Until every frame sent to the motors was answered or dropped (at most `timeout` s: a hung emulator)."""
        if self.faults.delay_reply_s:
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
        bus, faults = self.bus, self.faults
        if msg.is_error_frame or msg.arbitration_id not in self.motors:
            return
        self.frames_in += 1
        motor_id, data = msg.arbitration_id, bytes(msg.data)
        if faults.bus_off:
            if not self._bus_off_sent:
                bus.send(can.Message(is_error_frame=True, arbitration_id=CAN_ERR_BUSOFF, data=bytes(8), is_extended_id=True))
                self._bus_off_sent = True
            return
        if len(data) != 8:
            return  # the firmware ignores malformed frames
        if data[:7] == b"\xff" * 7:
            self._special(motor_id, data)
        else:
            self._pending[motor_id] = data
        if faults.drop_reply_prob and faults.drop():
            return
        if faults.delay_reply_s:
            time.sleep(faults.delay_reply_s)
        if faults.corrupt_prob and faults.corrupt(b"x") != b"x":
            # A corrupted CAN frame fails the controllers' CRC: receivers see an error frame, not the data.
            bus.send(can.Message(is_error_frame=True, arbitration_id=CAN_ERR_PROT, data=bytes(8), is_extended_id=True))
            return
        bus.send(self._status[motor_id])
        self.frames_out += 1

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
        motor, ranges, variant = self.motors[motor_id]
        position, velocity, torque = motor.reading(self.plant)
        if variant == "damiao":
            state = motor.error_code or (1 if motor.enabled else 0)
            data = mit.encode_reply(ranges, variant, motor_id, position, velocity, torque, motor.temperature, motor.temperature, state)
        else:
            data = mit.encode_reply(ranges, variant, motor_id, position, velocity, torque, motor.temperature, error_code=motor.error_code)
        self._status[motor_id] = can.Message(arbitration_id=motor_id, data=data, is_extended_id=False)

    def _inject(self, motor_id: int, motor: EmulatedMotor, over_temp_code: int) -> None:
        if motor_id in self.faults.error_codes:
            motor.error_code = self.faults.error_codes.pop(motor_id)
        if motor_id in self.faults.over_temperature:
            motor.temperature = max(motor.temperature, 120.0)
            motor.error_code = motor.error_code or over_temp_code

    def close(self) -> None:
        super().close()
        self.bus.shutdown()


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
        self._status: dict[int, bytes] = {}

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
        if self.faults.delay_reply_s:
            time.sleep(self.faults.delay_reply_s)
        try:
            os.write(self.fd, self.faults.corrupt(self._status[cmd.motor_id]))
            self.frames_out += 1
        except OSError:
            return

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
        self._status[motor_id] = rs485.encode_reply(
            motor_id, self._mode[motor_id], torque, velocity, position, round(motor.temperature), motor.error_code
        )


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
