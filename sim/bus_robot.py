"""The bus robot in its own process: `g1ctl robot --buses CONFIG`.

MuJoCo and the firmware emulators of a hardware config's buses (`hw.emulation.rig.SimulatedHardware`,
served), on the wall clock, behind real interfaces that a host in another process opens with the very
code a real robot gets: every serial port (RS-485 motors, the IMU) is a pseudo-terminal, every CAN bus
an slcan adapter on a pseudo-terminal (what a USB-CAN adapter speaks). Once its ports are open it
prints one JSON line saying where they are, `{"ready": true, "pid": N, "buses": {"can0": "/dev/pts/5",
...}}`; the host puts those paths into its copy of the config (`controller/runtime/bus_process.py`).

One loop on one thread: it waits on every port until the next 2 ms physics step is due, answers what
arrived (a batch of frames in one write; RS-485 ports first, whose next command waits on the reply),
and steps: the motors' control step, the physics, fresh status and an IMU frame, answering what
arrives between those parts, so that a frame waits for one part, not for the whole step. The physics
waits for the first command that holds a joint (the host's soft start): until then the G1 stands
still in its default pose, as the simulated G1 over DDS does. From then it follows the wall clock,
and catches up step by step (answering the ports between steps) when the machine held the process
back. A fault plan's faults strike at their times on the physics' clock. With `truth` it sends its
ground truth (time, qpos, qvel) every 10 ms as a datagram to that UNIX socket (the host's metrics
and fall detection). It stops after `duration_s`, or on SIGTERM/SIGINT, and returns what it counted,
the wire audit included.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

from hw.emulation.faults import load_fault_file, load_faults
from hw.emulation.rig import SimulatedHardware
from hw.errors import ConfigError
from hw.jointmap import HardwareConfig, hardware_config_path, load_hardware_config
from hw.yamlconfig import load_yaml
from sim.hardware_twin import MuJoCoPlant
from sim.robot import SimRobot
from sim.world import build_model

TRUTH_EVERY = 5  # physics steps between ground-truth datagrams (100 Hz)
GANTRY_HEIGHT_M = 0.25  # with `gantry`: the pelvis this far above standing (as `g1ctl hw` hangs simulated buses)
MAX_CATCH_UP_S = 0.5  # further behind the wall clock than this (the process was stopped): the physics skips ahead
LATE_STEP_S = 0.004  # a physics step that ran this much after its time is counted as late


@dataclass(frozen=True)
class BusRobotConfig:
    mjcf: Path  # the G1 model (the assets' g1_mjcf)
    hardware: str  # a bus robot's hardware config (name or path): `robot_process: true`
    faults: str | None = None  # a fault plan for its buses (name or path)
    seed: int = 0  # the IMU's noise (the run's seed, from the host that starts the robot)
    duration_s: float | None = None  # None: until stopped
    truth: str | None = None  # a UNIX datagram socket the ground truth goes to
    gantry: bool = False  # hang the pelvis in a virtual gantry (bring-up: a sweep cannot tip it over)


def load_bus_robot(name: str) -> HardwareConfig:
    cfg = load_hardware_config(name)
    if not cfg.robot_process:
        raise ConfigError(f"hardware config '{name}' is not a bus robot of its own process (robot_process: true): use sim-can-process")
    return cfg


def real_robot_yaml(name: str, ports: dict[str, str]) -> dict[str, Any]:
    """The bus robot's config (name or path) as a real robot's, on the ports it opened: `g1ctl run --hardware` with it
    drives the robot process as it would drive real adapters and serial ports (the registry's `real-buses`: no ground
    truth, no simulator in the run). Its YAML as written, with the ports, `simulated: false`, and no `imu_model`
    (a real IMU brings its own noise)."""
    data = dict(load_yaml(hardware_config_path(name)))
    buses = {bus: dict(fields) for bus, fields in data["buses"].items()}
    for bus, fields in buses.items():
        fields["channel" if fields["kind"] == "can" else "port"] = ports[bus]
    data.pop("imu_model", None)
    data.pop("robot_process", None)
    return {**data, "description": f"{data.get('description', name)} (the robot process's ports, as a real robot's)",
            "simulated": False, "buses": buses}  # fmt: skip


def run_bus_robot(cfg: BusRobotConfig, announce: Callable[[dict[str, Any]], None]) -> dict[str, Any]:
    """Serve the robot until the duration ends or a stop signal comes; `announce` is given where its ports are."""
    stop = {"requested": False}

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop["requested"] = True

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    server = _Server(cfg)
    try:
        announce({"ready": True, "pid": os.getpid(), "buses": server.ports()})
        start = time.monotonic()
        while not stop["requested"] and (cfg.duration_s is None or time.monotonic() - start < cfg.duration_s):
            server.run_once()
        return server.report()
    finally:
        server.close()
        for s, handler in previous.items():
            signal.signal(s, handler)


class _Server:
    def __init__(self, cfg: BusRobotConfig) -> None:
        hardware = load_bus_robot(cfg.hardware)
        plans = None
        if cfg.faults is not None:
            imu_bus = hardware.imu.bus if hardware.imu is not None else None
            plans = load_faults(load_fault_file(cfg.faults), cfg.faults, list(hardware.buses), imu_bus)
        self.cfg = cfg
        self.robot = SimRobot(build_model(cfg.mjcf))
        self.plant = MuJoCoPlant(self.robot, gantry_height=GANTRY_HEIGHT_M if cfg.gantry else None)
        self.dt = self.robot.timestep
        self.rig = SimulatedHardware(hardware, self.plant, plans, cfg.seed, served=True)
        self._fds = list(self.rig.ports)
        self._truth = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) if cfg.truth is not None else None
        if self._truth is not None:
            self._truth.setblocking(False)
        self.physics_start: float | None = None  # wall time the physics' clock counts from (the first command that holds)
        self.next_step = time.monotonic()
        self.steps = self.late_steps = self.skipped_steps = self.truth_sent = self.truth_lost = 0
        self.step_times: list[float] = []  # s: one physics step with the motors' control step, status and IMU frame
        self.serve_times: list[float] = []  # s: answering what had arrived on the ready ports

    def ports(self) -> dict[str, str]:
        buses = self.rig.host_config.buses
        return {name: bus.channel if bus.kind == "can" else bus.port for name, bus in buses.items()}

    def run_once(self) -> None:
        """Answer the ports until the next step is due, then step (catching up with the wall clock)."""
        self._serve(max(self.next_step - time.monotonic(), 0.0))
        now = time.monotonic()
        if now < self.next_step:
            return
        if now - self.next_step > LATE_STEP_S:
            self.late_steps += 1
        if self.physics_start is None:
            self.rig.step(physics=False)  # the motors' control step: the commands decoded, the physics held
            if "active" in self.rig.audit.state:  # a motor holds a joint: the host's soft start began
                self.physics_start = now
            self.next_step = max(self.next_step + self.dt, now)
            return
        behind = now - self.physics_start - self.plant.time()
        if behind > MAX_CATCH_UP_S:  # stopped for a while: skip ahead rather than race through seconds of physics
            skipped = int(behind / self.dt)
            self.skipped_steps += skipped
            self.physics_start += skipped * self.dt
        while self.plant.time() < time.monotonic() - self.physics_start:  # the physics keeps up with the wall clock
            self._step()
            self._serve(0.0)  # a reply does not wait for the physics to catch up
        self.next_step = self.physics_start + self.plant.time()

    def _step(self) -> None:
        t0 = time.perf_counter()
        self.rig.step(between=self._answer_arrived)  # a motor answers while its control loop runs
        self.step_times.append(time.perf_counter() - t0)
        self.steps += 1
        if self._truth is not None and self.cfg.truth is not None and self.steps % TRUTH_EVERY == 0:
            data = self.robot.data
            sample = np.concatenate(([time.monotonic(), data.time], data.qpos, data.qvel)).tobytes()  # the clock is the machine's
            try:
                self._truth.sendto(sample, self.cfg.truth)
                self.truth_sent += 1
            except OSError:  # nobody listens (yet), or the listener is behind: the newest sample counts, not this one
                self.truth_lost += 1

    def _answer_arrived(self) -> None:
        self._serve(0.0)

    def _serve(self, timeout: float) -> None:
        due = [d for e in self.rig.emulators if (d := e.next_due()) is not None]
        if due:
            timeout = max(min(timeout, min(due) - time.monotonic()), 0.0)
        ready, _, _ = select.select(self._fds, [], [], timeout)
        if ready:
            t0 = time.perf_counter()
            self.rig.serve(ready)
            self.serve_times.append(time.perf_counter() - t0)
        else:
            self.rig.serve(ready)  # replies a fault held back, when due

    def report(self) -> dict[str, Any]:
        rig = self.rig
        return {
            "steps": self.steps, "sim_seconds": round(self.plant.time(), 3), "late_steps": self.late_steps,
            "step_ms": percentiles_ms(self.step_times), "serve_ms": percentiles_ms(self.serve_times),
            "skipped_steps": self.skipped_steps, "truth_sent": self.truth_sent, "truth_lost": self.truth_lost,
            "frames_in": sum(e.frames_in for e in rig.emulators), "frames_out": sum(e.frames_out for e in rig.emulators),
            "bad_lines": sum(getattr(e, "bad_lines", 0) for e in rig.emulators),
            "crc_errors": sum(getattr(e, "crc_errors", 0) for e in rig.emulators),
            "imu_frames": rig.imu.sequence if rig.imu is not None else 0, "imu_overflows": rig.imu.overflows if rig.imu is not None else 0,
            "wire": rig.audit.report(),
        }  # fmt: skip

    def close(self) -> None:
        if self._truth is not None:
            with contextlib.suppress(OSError):
                self._truth.close()
        self.rig.close()
        self.robot.close()


def percentiles_ms(samples_s: list[float]) -> dict[str, float]:
    """p50 and p99 in milliseconds, as the run reports write them (`controller.reports`, which sim/ does not import)."""
    if not samples_s:
        return {"p50": float("nan"), "p99": float("nan")}
    p50, p99 = np.percentile(np.asarray(samples_s) * 1e3, [50, 99])
    return {"p50": round(float(p50), 4), "p99": round(float(p99), 4)}
