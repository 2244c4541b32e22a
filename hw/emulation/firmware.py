"""Firmware emulators: MIT-mode motors on a CAN bus, GO-M8010-style motors on RS-485, a serial IMU."""

from __future__ import annotations

import os
import select
import threading
import time

import can

from hw.drivers import MotorCommand
from hw.emulation.faults import FaultPlan
from hw.emulation.motor import EmulatedMotor
from hw.emulation.plant import Plant
from hw.protocols import imu as imu_frame
from hw.protocols import mit
from hw.protocols import unitree_rs485 as rs485

CUBEMARS_OVER_TEMPERATURE = 1
DAMIAO_COIL_OVER_TEMPERATURE = 0xC
RS485_OVERHEAT = 1


class _Emulator:
    """A background thread answering frames until `close()`."""

    def __init__(self, name: str, plant: Plant, faults: FaultPlan | None) -> None:
        self.name = name
        self.plant = plant
        self.faults = faults or FaultPlan()
        self.frames_in = 0
        self.frames_out = 0
        self._running = True
        self._thread = threading.Thread(target=self._serve, name=f"emulator-{name}", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def _serve(self) -> None:
        raise NotImplementedError

    def close(self) -> None:
        self._running = False
        if self._thread.is_alive():
            self._thread.join(timeout=1.0)


class MitBusEmulator(_Emulator):
    """MIT-mode motors on one virtual CAN bus; each answers only frames to its own id."""

    def __init__(
        self,
        name: str,
        bus: can.BusABC,
        motors: dict[int, tuple[EmulatedMotor, mit.MitRanges, mit.ReplyVariant]],
        plant: Plant,
        faults: FaultPlan | None = None,
    ) -> None:
        super().__init__(name, plant, faults)
        self.bus = bus
        self.motors = motors
        self._bus_off_sent = False

    def _serve(self) -> None:
        while self._running:
            msg = self.bus.recv(timeout=0.05)
            if msg is None or msg.is_error_frame or msg.arbitration_id not in self.motors:
                continue
            self.frames_in += 1
            if self.faults.bus_off:
                if not self._bus_off_sent:
                    self.bus.send(can.Message(is_error_frame=True, arbitration_id=0x20000004, data=bytes(8), is_extended_id=True))
                    self._bus_off_sent = True
                continue
            reply = self._handle(msg.arbitration_id, bytes(msg.data))
            if reply is None or self.faults.drop():
                continue
            if self.faults.delay_reply_s:
                time.sleep(self.faults.delay_reply_s)
            self.bus.send(can.Message(arbitration_id=msg.arbitration_id, data=self.faults.corrupt(reply), is_extended_id=False))
            self.frames_out += 1

    def _handle(self, motor_id: int, data: bytes) -> bytes | None:
        motor, ranges, variant = self.motors[motor_id]
        over_temp_code = DAMIAO_COIL_OVER_TEMPERATURE if variant == "damiao" else CUBEMARS_OVER_TEMPERATURE
        with self.plant.lock:
            if len(data) != 8:
                return None  # the firmware ignores malformed frames
            special = mit.SPECIAL_FRAMES.get(data)
            command = None
            if special == "enter":
                motor.enabled, motor.error_code = True, 0  # re-entering motor mode clears a latched error
            elif special == "exit":
                motor.enabled = False
            elif special == "zero":
                motor.set_zero(self.plant)
            else:
                c = mit.decode_command(ranges, data)  # quantized exactly as the firmware sees it
                command = MotorCommand(q=c.position, dq=c.velocity, kp=c.kp, kd=c.kd, tau=c.torque)
            self._inject(motor_id, motor, over_temp_code)
            motor.apply(self.plant, command, over_temp_code, motor_id in self.faults.stuck)
            position, velocity, torque = motor.reading(self.plant)
        if variant == "damiao":
            state = motor.error_code or (1 if motor.enabled else 0)
            return mit.encode_reply(ranges, variant, motor_id, position, velocity, torque, motor.temperature, motor.temperature, state)
        return mit.encode_reply(ranges, variant, motor_id, position, velocity, torque, motor.temperature, error_code=motor.error_code)

    def _inject(self, motor_id: int, motor: EmulatedMotor, over_temp_code: int) -> None:
        if motor_id in self.faults.error_codes:
            motor.error_code = self.faults.error_codes.pop(motor_id)
        if motor_id in self.faults.over_temperature:
            motor.temperature = max(motor.temperature, 120.0)
            motor.error_code = motor.error_code or over_temp_code

    def tick(self) -> None:
        """Per physics step: enforce each motor's command watchdog."""
        with self.plant.lock:
            for motor_id, (motor, _, variant) in self.motors.items():
                code = DAMIAO_COIL_OVER_TEMPERATURE if variant == "damiao" else CUBEMARS_OVER_TEMPERATURE
                motor.apply(self.plant, None, code, motor_id in self.faults.stuck)

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
        motor = self.motors.get(cmd.motor_id)
        if motor is None:
            return  # another motor's id, or broadcast: no reply
        self.frames_in += 1
        with self.plant.lock:
            if cmd.motor_id in self.faults.error_codes:
                motor.error_code = self.faults.error_codes.pop(cmd.motor_id)
            if cmd.motor_id in self.faults.over_temperature:
                motor.temperature, motor.error_code = max(motor.temperature, 120.0), motor.error_code or RS485_OVERHEAT
            if cmd.mode == rs485.MODE_BRAKE:
                motor.enabled, motor.error_code = False, 0
                command = None
            else:
                motor.enabled = True
                command = MotorCommand(q=cmd.position, dq=cmd.speed, kp=cmd.kp, kd=cmd.kd, tau=cmd.torque)
            motor.apply(self.plant, command, RS485_OVERHEAT, cmd.motor_id in self.faults.stuck)
            position, velocity, torque = motor.reading(self.plant)
        if self.faults.drop():
            return
        if self.faults.delay_reply_s:
            time.sleep(self.faults.delay_reply_s)
        reply = rs485.encode_reply(cmd.motor_id, cmd.mode, torque, velocity, position, round(motor.temperature), motor.error_code)
        try:
            os.write(self.fd, self.faults.corrupt(reply))
            self.frames_out += 1
        except OSError:
            return

    def tick(self) -> None:
        with self.plant.lock:
            for motor_id, motor in self.motors.items():
                motor.apply(self.plant, None, RS485_OVERHEAT, motor_id in self.faults.stuck)


class ImuEmulator:
    """Writes one IMU frame per `emit()` to the far end of a pseudo-terminal."""

    def __init__(self, fd: int, plant: Plant, faults: FaultPlan | None = None) -> None:
        self.fd = fd
        self.plant = plant
        self.faults = faults or FaultPlan()
        self.sequence = 0
        self.overflows = 0
        os.set_blocking(fd, False)

    def emit(self) -> None:
        if self.faults.silent:
            return
        with self.plant.lock:
            quat, gyro, acc = self.plant.imu_reading()
        sample = imu_frame.ImuSample(self.sequence, quat, gyro, acc)  # type: ignore[arg-type]
        self.sequence = (self.sequence + 1) & 0xFFFF
        try:
            os.write(self.fd, self.faults.corrupt(imu_frame.encode_imu(sample)))
        except BlockingIOError:
            self.overflows += 1  # nobody reads: the frame is lost, as on a real UART

    def close(self) -> None:
        pass
