"""Simulated hardware: an emulator behind every bus of a hardware config.

Virtual CAN channels and pseudo-terminals get fresh names for each rig, so parallel runs
never hear each other. The host side opens the rewritten config (`host_config`) exactly
as it would open real hardware; only the channel names and port paths differ.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import tty
import uuid

from can.interfaces.virtual import VirtualBus

from hw.emulation.faults import FaultPlan
from hw.emulation.firmware import ImuEmulator, MitBusEmulator, Rs485PortEmulator
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
    The IMU measures as `cfg.imu_model` states (its defaults when the config has none), its noise seeded by `seed` (the run's)."""

    def __init__(self, cfg: HardwareConfig, plant: Plant, faults: dict[str, FaultPlan] | None = None, seed: int = 0) -> None:
        self.plant = plant
        self.faults = faults or {}
        names = tuple(cfg.joints)
        self.audit = WireAudit(names, WireLimits.of(names, cfg.joints))
        token = uuid.uuid4().hex[:8]
        models = load_motor_models()
        self.emulators: list[MitBusEmulator | Rs485PortEmulator] = []
        self.imu: ImuEmulator | None = None
        self._fds: list[int] = []
        host_buses: dict[str, BusConfig] = {}
        try:
            for name, bus in cfg.buses.items():
                plan = self.faults.setdefault(name, FaultPlan())
                joints = {j: jc for j, jc in cfg.joints.items() if jc.bus == name}
                if bus.kind == "can":
                    if bus.interface != "virtual":
                        raise ConfigError(f"simulated hardware needs 'interface: virtual' on CAN bus '{name}', it has '{bus.interface}'")
                    host_buses[name] = dataclasses.replace(bus, channel=f"{bus.channel}-{token}")
                    emu_bus = VirtualBus(channel=host_buses[name].channel, receive_own_messages=False)
                    motors: dict[int, tuple[EmulatedMotor, MitRanges, ReplyVariant]] = {}
                    for jname, jc in joints.items():
                        ranges = models[jc.model]
                        motors[jc.id] = (EmulatedMotor(jname, jc, ranges.t_max, audit=self.audit), ranges, jc.reply)
                    self.emulators.append(MitBusEmulator(name, emu_bus, motors, plant, plan))
                else:
                    master, slave = os.openpty()
                    tty.setraw(slave)
                    self._fds += [master, slave]
                    host_buses[name] = dataclasses.replace(bus, port=os.ttyname(slave))
                    if cfg.imu is not None and cfg.imu.bus == name:
                        model = ImuModel(cfg.imu_model or ImuModelConfig(), seed)
                        self.imu = ImuEmulator(master, plant, plan, reader_fd=slave, model=model)
                    else:
                        rs_motors = {
                            jc.id: EmulatedMotor(jname, jc, torque_max=jc.torque_limit / jc.gear_ratio, audit=self.audit)
                            for jname, jc in joints.items()
                        }
                        self.emulators.append(Rs485PortEmulator(name, master, rs_motors, plant, plan))
        except Exception:
            self.close()
            raise
        self.host_config = dataclasses.replace(cfg, buses=host_buses)
        for emulator in self.emulators:
            emulator.start()

    def await_replies(self) -> None:
        """Returns once every frame sent to the CAN motors has been answered or its reply dropped (`HardwareRobot`'s hook)."""
        for emulator in self.emulators:
            if isinstance(emulator, MitBusEmulator):
                emulator.wait_answered(ANSWER_TIMEOUT_S)

    def step(self) -> None:
        """One physics step: the motors' control step, physics, then fresh status and IMU frames (the IMU's readable by the host).
        Raises `EmulatorError` once an emulator's thread died: its motors would only go silent."""
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
        step = getattr(self.plant, "step", None)
        if step is not None:
            step()
        for emulator in self.emulators:
            emulator.sample()
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
