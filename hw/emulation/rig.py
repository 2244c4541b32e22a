"""Simulated hardware: an emulator behind every bus of a hardware config.

Virtual CAN channels and pseudo-terminals get fresh names for each rig, so parallel runs
never hear each other. The host side opens the rewritten config (`host_config`) exactly
as it would open real hardware; only the channel names and port paths differ.

In the host's process (`served=False`) CAN buses are python-can `virtual` channels and each
emulator answers on a thread of its own. In the bus robot process (`served=True`, `g1ctl robot
--buses`) every bus is a pseudo-terminal, CAN as an slcan adapter, and the process's loop
answers whatever port is readable (`ports`, `serve`): a host in another process opens them.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import tty
import uuid
from collections.abc import Callable

from can.interfaces.virtual import VirtualBus

from hw.emulation.faults import FaultPlan
from hw.emulation.firmware import ImuEmulator, MitBusEmulator, Rs485PortEmulator, SlcanMitEmulator
from hw.emulation.imu_model import ImuModel, ImuModelConfig
from hw.emulation.motor import EmulatedMotor
from hw.emulation.plant import Plant
from hw.emulation.wire_audit import WireAudit, WireLimits
from hw.errors import ConfigError, EmulatorError
from hw.jointmap import BusConfig, HardwareConfig, load_motor_models
from hw.protocols.mit import MitRanges, ReplyVariant

ANSWER_TIMEOUT_S = 1.0  # bounds the wait for the CAN emulators' answers: only a hung emulator takes this long


class SimulatedHardware:
    """Starts an emulator behind every bus of `cfg`; close() stops them. `audit` holds what the motors decoded.
    The IMU measures as `cfg.imu_model` states (its defaults when the config has none), its noise seeded by `seed` (the run's).
    `served`: the bus robot process's rig (every bus a pseudo-terminal, answered from its loop)."""

    def __init__(
        self, cfg: HardwareConfig, plant: Plant, faults: dict[str, FaultPlan] | None = None, seed: int = 0, served: bool = False
    ) -> None:
        self.plant = plant
        self.faults = faults or {}
        names = tuple(cfg.joints)
        self.audit = WireAudit(names, WireLimits.of(names, cfg.joints))
        token = uuid.uuid4().hex[:8]
        models = load_motor_models()
        self.emulators: list[MitBusEmulator | Rs485PortEmulator] = []
        self.imu: ImuEmulator | None = None
        self.ports: dict[int, MitBusEmulator | Rs485PortEmulator] = {}  # served: the port (pseudo-terminal) each emulator answers
        self._served = served
        self._fds: list[int] = []
        host_buses: dict[str, BusConfig] = {}
        try:
            for name, bus in cfg.buses.items():
                plan = self.faults.setdefault(name, FaultPlan())
                joints = {j: jc for j, jc in cfg.joints.items() if jc.bus == name}
                if bus.kind == "can":
                    wanted = "slcan" if served else "virtual"
                    if bus.interface != wanted:
                        where = "the bus robot process" if served else "simulated hardware"
                        raise ConfigError(f"{where} needs 'interface: {wanted}' on CAN bus '{name}', it has '{bus.interface}'")
                    motors: dict[int, tuple[EmulatedMotor, MitRanges, ReplyVariant]] = {}
                    for jname, jc in joints.items():
                        ranges = models[jc.model]
                        motors[jc.id] = (EmulatedMotor(jname, jc, ranges.t_max, audit=self.audit), ranges, jc.reply)
                    if served:
                        master, path = self._pseudo_terminal()
                        host_buses[name] = dataclasses.replace(bus, channel=path)
                        self.emulators.append(SlcanMitEmulator(name, master, motors, plant, plan))
                        self.ports[master] = self.emulators[-1]
                        continue
                    host_buses[name] = dataclasses.replace(bus, channel=f"{bus.channel}-{token}")
                    emu_bus = VirtualBus(channel=host_buses[name].channel, receive_own_messages=False)
                    self.emulators.append(MitBusEmulator(name, emu_bus, motors, plant, plan))
                else:
                    master, path = self._pseudo_terminal()
                    slave = self._fds[-1]
                    host_buses[name] = dataclasses.replace(bus, port=path)
                    if cfg.imu is not None and cfg.imu.bus == name:
                        model = ImuModel(cfg.imu_model or ImuModelConfig(), seed)
                        # In this process the host reads on a thread's time: a frame must be readable before a cycle looks.
                        self.imu = ImuEmulator(master, plant, plan, reader_fd=None if served else slave, model=model)
                    else:
                        rs_motors = {
                            jc.id: EmulatedMotor(jname, jc, torque_max=jc.torque_limit / jc.gear_ratio, audit=self.audit)
                            for jname, jc in joints.items()
                        }
                        self.emulators.append(Rs485PortEmulator(name, master, rs_motors, plant, plan))
                        if served:
                            self.ports[master] = self.emulators[-1]
        except Exception:
            self.close()
            raise
        self.host_config = dataclasses.replace(cfg, buses=host_buses)
        for emulator in self.emulators:
            if served:
                emulator.start_served()
            else:
                emulator.start()

    def _pseudo_terminal(self) -> tuple[int, str]:
        """A pseudo-terminal in raw mode: the emulator's end, and the path the host opens. The emulator keeps the host's
        end open too, so that a host closing and opening it again never leaves the emulator's end hung up."""
        master, slave = os.openpty()
        tty.setraw(slave)
        self._fds += [master, slave]
        if self._served:
            os.set_blocking(master, False)
        return master, os.ttyname(slave)

    def serve(self, ready: list[int]) -> None:
        """Served: answer what arrived on the ready ports, and send the delayed replies that are due. RS-485 ports
        first: a half-duplex bus sends its next command only once this reply is in, while a CAN bus sent all of its."""
        for fd in sorted(ready, key=self._serial_first):
            self.ports[fd].serve()
        for emulator in self.emulators:
            if emulator.next_due() is not None:
                emulator.flush_due()

    def _serial_first(self, fd: int) -> bool:
        return not isinstance(self.ports[fd], Rs485PortEmulator)

    def await_replies(self) -> None:
        """Returns once every frame sent to the CAN motors has been answered or its reply dropped (`HardwareRobot`'s hook)."""
        for emulator in self.emulators:
            if isinstance(emulator, MitBusEmulator):
                emulator.wait_answered(ANSWER_TIMEOUT_S)

    def step(self, physics: bool = True, between: Callable[[], None] | None = None) -> None:
        """One physics step: the motors' control step, physics, then fresh status and IMU frames (the IMU's readable by the host).
        `physics=False`: the same but for the physics (a robot that has not been given a command to hold yet stands still).
        `between` (served): called between the step's parts, so that a frame that arrives meanwhile is answered within a
        part's time, as a motor's firmware answers while its control loop runs, not after the whole step.
        Raises `EmulatorError` once an emulator's thread died: its motors would only go silent."""
        pause = between if between is not None else _nothing
        for emulator in self.emulators:
            if emulator.error is not None:
                exc = emulator.error
                raise EmulatorError(
                    f"the firmware emulator of bus '{emulator.name}' died: {type(exc).__name__}: {exc}; "
                    "its motors no longer answer, so the run stops (the log has the traceback)"
                ) from exc
        now = self.plant.time()
        for plan in self.faults.values():
            plan.update(now)  # faults held back to their start time
        for emulator in self.emulators:
            emulator.tick()
            pause()
        step = getattr(self.plant, "step", None)
        if step is not None and physics:
            step()
            pause()
        for emulator in self.emulators:
            emulator.sample()
            pause()
        if self.imu is not None:
            self.imu.emit()

    def close(self) -> None:
        for emulator in self.emulators:
            emulator.close()
        self.emulators = []
        for fd in self._fds:
            with contextlib.suppress(OSError):
                os.close(fd)
        self._fds = []

    def __enter__(self) -> SimulatedHardware:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _nothing() -> None:
    return None
