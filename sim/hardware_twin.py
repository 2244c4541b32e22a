"""Simulated hardware driven by MuJoCo: the firmware emulators of `hw.emulation` behind
fresh virtual CAN channels and pseudo-terminals, with the G1 physics as their plant.

The host side opens the rewritten config (`SimulatedHardware.host_config`) exactly as it
would open real hardware; only the channel names and port paths differ.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import threading
import tty
import uuid

import can
import numpy as np

from hw.emulation.faults import FaultPlan
from hw.emulation.firmware import ImuEmulator, MitBusEmulator, Rs485PortEmulator
from hw.emulation.motor import EmulatedMotor
from hw.errors import ConfigError
from hw.jointmap import BusConfig, HardwareConfig, load_motor_models
from hw.protocols.mit import MitRanges, ReplyVariant
from hw.types import JointCommand
from sim.robot import SimRobot

GRAVITY = 9.81


class MuJoCoPlant:
    """The emulators' view of the simulated G1: joint states and per-joint PD laws."""

    def __init__(self, robot: SimRobot) -> None:
        self.robot = robot
        self.lock = threading.RLock()
        names = robot.joint_names
        self._index = {name: i for i, name in enumerate(names)}
        n = len(names)
        self._q, self._dq, self._kp, self._kd, self._tau = (np.zeros(n) for _ in range(5))
        model, data = robot.model, robot.data
        self._qadr = [model.jnt_qposadr[model.joint(j).id] for j in names]
        self._vadr = [model.jnt_dofadr[model.joint(j).id] for j in names]
        self._aid = [model.actuator(j).id for j in names]
        self._data = data
        robot.damp()  # limp until the first command arrives: zero gains
        self.robot.write(JointCommand(q=self._q, dq=self._dq, kp=self._kp, kd=self._kd, tau_ff=self._tau))

    def time(self) -> float:
        return float(self._data.time)

    def joint_state(self, joint: str) -> tuple[float, float, float]:
        i = self._index[joint]
        d = self._data
        return float(d.qpos[self._qadr[i]]), float(d.qvel[self._vadr[i]]), float(d.actuator_force[self._aid[i]])

    def set_joint_command(self, joint: str, q: float, dq: float, kp: float, kd: float, tau: float) -> None:
        i = self._index[joint]
        self._q[i], self._dq[i], self._kp[i], self._kd[i], self._tau[i] = q, dq, kp, kd, tau

    def imu_reading(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        d = self._data
        w, x, y, z = d.qpos[3:7].tolist()
        # Specific force of a body at rest: gravity reaction rotated into the IMU frame.
        gx, gy, gz = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        return (w, x, y, z), tuple(d.qvel[3:6].tolist()), (gx * GRAVITY, gy * GRAVITY, gz * GRAVITY)

    def step(self) -> None:
        with self.lock:
            self.robot.write(
                JointCommand(q=self._q.copy(), dq=self._dq.copy(), kp=self._kp.copy(), kd=self._kd.copy(), tau_ff=self._tau.copy())
            )
            self.robot.step(1)


class SimulatedHardware:
    """Starts an emulator behind every bus of `cfg`; close() stops them."""

    def __init__(self, cfg: HardwareConfig, plant: MuJoCoPlant, faults: dict[str, FaultPlan] | None = None) -> None:
        self.plant = plant
        self.faults = faults or {}
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
                    emu_bus = can.Bus(interface="virtual", channel=host_buses[name].channel, receive_own_messages=False)
                    motors: dict[int, tuple[EmulatedMotor, MitRanges, ReplyVariant]] = {}
                    for jname, jc in joints.items():
                        ranges = models[jc.model]
                        motors[jc.id] = (EmulatedMotor(jname, jc, ranges.t_max), ranges, jc.reply)
                    self.emulators.append(MitBusEmulator(name, emu_bus, motors, plant, plan))
                else:
                    master, slave = os.openpty()
                    tty.setraw(slave)
                    self._fds += [master, slave]
                    host_buses[name] = dataclasses.replace(bus, port=os.ttyname(slave))
                    if cfg.imu is not None and cfg.imu.bus == name:
                        self.imu = ImuEmulator(master, plant, plan)
                    else:
                        rs_motors = {
                            jc.id: EmulatedMotor(jname, jc, torque_max=jc.torque_limit / jc.gear_ratio) for jname, jc in joints.items()
                        }
                        self.emulators.append(Rs485PortEmulator(name, master, rs_motors, plant, plan))
        except Exception:
            self.close()
            raise
        self.host_config = dataclasses.replace(cfg, buses=host_buses)
        for emulator in self.emulators:
            emulator.start()

    def step(self) -> None:
        """One physics step: motor watchdogs, physics, then a fresh IMU frame."""
        for emulator in self.emulators:
            emulator.tick()
        self.plant.step()
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
