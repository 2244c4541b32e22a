"""The G1 over DDS as a run backend: 500 Hz cycles on the wall clock between control ticks.

`DdsBackend` drives a `DdsRobot` (any robot on the config's domain): the run's time is the wall
clock, and between control ticks the backend runs one `cycle()` every 2 ms, counting the cycles
that start late. `RealDdsBackend` is a real G1: no ground truth, a fall is the IMU's tilt.
`SimulatedDdsBackend` first starts the simulated G1 (`g1ctl robot --dds`) in a child process on
the config's domain and interface, and mirrors the child's ground truth (`sim/truth`) into the
run's own copy of the model, for the metrics, fall detection and the video. The robot process is
stopped, and its counters kept, on every exit path. `build_real_dds` and `build_simulated_dds`
make them from the plan of a run (the registry's `real-dds` and `simulated-dds`); only the
simulated one imports MuJoCo, for its mirror.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from contextlib import ExitStack
from typing import TYPE_CHECKING, Any

import numpy as np

from controller.reports import percentiles_ms
from controller.runtime.backend import Backend
from controller.runtime.backend_registry import BuiltBackend
from controller.runtime.loop import Clock, RunClock
from hw import g1, quat
from hw.dds.config import DdsHardwareConfig
from hw.dds.robot import DdsRobot
from hw.errors import HardwareFault
from hw.g1 import CONTROL_CYCLE_HZ
from hw.robot import Lifecycle
from hw.types import RobotState

if TYPE_CHECKING:
    from controller.assets import Assets
    from controller.runtime.run_plan import RunPlan
    from sim.robot import SimRobot

PERIOD_S = 1.0 / CONTROL_CYCLE_HZ
SIM_SOFT_START_S = 0.2  # the simulated robot starts in the default pose: nothing to ramp
ROBOT_STOP_TIMEOUT_S = 10.0
MAX_TILT_DEG = 60.0  # the simulator's fall threshold (`sim.robot.FallConfig`), from a real robot's IMU


class DdsBackend(Backend):
    paced_on_wall_clock = True

    def __init__(self, robot: DdsRobot, config_name: str, clock: Clock | None = None) -> None:
        """`clock`: the run's time line, the one `robot` stamps its states with (default: the wall clock from now on)."""
        self.host = robot
        self.robot = robot
        self.config_name = config_name
        self._clock = clock or RunClock()
        self._next_cycle: float | None = None
        self.cycle_times: list[float] = []
        self.late_cycles = 0  # cycles that started more than one period after their deadline

    def start(self) -> None:
        """Configure (release the motion service, find the robot), then the soft start; raises HardwareFault on a fault."""
        self.host.configure()
        self.host.activate()
        self._next_cycle = self._clock.now()
        while self.host.state is Lifecycle.ACTIVATING:
            self.advance_to(self._next_cycle)
        if self.host.state is Lifecycle.ERROR:
            raise HardwareFault(f"soft start failed: {'; '.join(self.host.faults)}")

    def now(self) -> float:
        return self._clock.now()

    def advance_to(self, t: float) -> None:
        """Cycles on their 2 ms deadlines up to `t`; a schedule that fell behind re-anchors instead of bursting."""
        if self._next_cycle is None:
            self._next_cycle = self._clock.now()
        while self._next_cycle <= t:
            self._clock.sleep_until(self._next_cycle)
            self.cycle()
            self._next_cycle += PERIOD_S
            now = self._clock.now()
            if now > self._next_cycle + PERIOD_S:
                self.late_cycles += 1
                self._next_cycle = now
        self._clock.sleep_until(t)

    def cycle(self) -> None:
        t0 = time.perf_counter()
        self.host.cycle()
        self.cycle_times.append(time.perf_counter() - t0)

    def fault(self) -> str | None:
        return "; ".join(self.host.faults) if self.host.state is Lifecycle.ERROR else None

    def report(self) -> dict[str, Any]:
        c = self.host.counters()
        return {
            "config": self.config_name,
            "transport": "dds",
            "cycle_ms": percentiles_ms(self.cycle_times),
            "cycles": len(self.cycle_times),
            "late_cycles": self.late_cycles,
            "commands_sent": c.commands_sent,
            "states_received": c.states_received,
            "crc_errors": c.crc_errors,
            "bad_frames": c.bad_frames,
            "mode_machine_changes": c.mode_machine_changes,
            "released_mode": self.host.released_mode,
        } | self.host.lifecycle_report()

    def close(self) -> None:
        self.host.close()


class RealDdsBackend(DdsBackend):
    """A real G1: no ground truth; a fall is the IMU's pelvis tilt past `MAX_TILT_DEG`."""

    def has_fallen(self) -> bool:
        up_z = float(quat.rotate(self.host.read().base_quat, np.array([0.0, 0.0, 1.0]))[2])
        return up_z < math.cos(math.radians(MAX_TILT_DEG))


class RobotProcess:
    """`g1ctl robot --dds` as a child process: started on a domain, stopped with SIGTERM, its JSON counters kept."""

    def __init__(self, cfg: DdsHardwareConfig, assets_dir: str | None = None, extra_args: tuple[str, ...] = (), truth: bool = True) -> None:
        dds = cfg.dds
        command = [sys.executable, "-m", "controller.cli"]
        if assets_dir is not None:
            command += ["--assets-dir", assets_dir]
        command += [
            "robot",
            "--dds",
            "--domain",
            str(dds.domain),
            "--interface",
            dds.interface,
            *(["--truth"] if truth else []),
            *extra_args,
        ]
        self._stdout = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 - open for the child's lifetime, closed in stop()
        self._stderr = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115
        self.process = subprocess.Popen(command, stdout=self._stdout, stderr=self._stderr, env={**os.environ, "PYTHONUNBUFFERED": "1"})
        self.report: dict[str, Any] | None = None

    @property
    def pid(self) -> int:
        return self.process.pid

    def stop(self) -> dict[str, Any]:
        """SIGTERM, wait, and what the robot counted (or how it ended, when it died)."""
        if self.report is not None:
            return self.report
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        try:
            code = self.process.wait(ROBOT_STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.process.kill()
            code = self.process.wait()
        self._stdout.seek(0)
        self._stderr.seek(0)
        out, err = self._stdout.read(), self._stderr.read()
        self._stdout.close()
        self._stderr.close()
        try:
            counters = json.loads(out.strip().splitlines()[-1]) if out.strip() else {}
        except json.JSONDecodeError:
            counters = {}
        self.report = {"pid": self.process.pid, "exit_code": code, **counters}
        if code != 0:
            self.report["stderr_tail"] = err.strip().splitlines()[-3:]
        return self.report


class SimulatedDdsBackend(DdsBackend):
    """The simulated G1 in its own process over DDS; `mirror` (the run's copy of the model) follows its ground truth."""

    def __init__(
        self, mirror: SimRobot, cfg: DdsHardwareConfig, config_name: str, assets_dir: str | None = None, robot_args: tuple[str, ...] = ()
    ) -> None:
        """`robot_args`: more flags for `g1ctl robot --dds` (e.g. `--remote SCENARIO`: its wireless remote plays a scenario)."""
        from hw.dds.domains import claim_domain  # noqa: PLC0415
        from hw.dds.session import DdsSession  # noqa: PLC0415 - the g1 extra
        from sim.dds_truth import TRUTH_TOPIC, SimTruth_  # noqa: PLC0415

        self.domain = claim_domain(cfg.dds.domain)  # parallel runs on one machine each on a domain of their own
        dds = dataclasses.replace(cfg.dds, domain=self.domain.domain)
        cfg = dataclasses.replace(cfg, dds=dds, safety=dataclasses.replace(cfg.safety, soft_start_time=SIM_SOFT_START_S))
        self.mirror = mirror
        try:
            self.robot_process = RobotProcess(cfg, assets_dir, robot_args)
        except Exception:
            self.domain.release()
            raise
        try:
            self._truth_session = DdsSession(cfg.dds)
            self._truth = self._truth_session.reader(TRUTH_TOPIC, SimTruth_)
            clock = RunClock()
            super().__init__(DdsRobot(cfg, clock=clock.now), config_name, clock)
        except Exception:
            self.robot_process.stop()
            self.domain.release()
            raise
        self.truth_time: float | None = None

    def advance_to(self, t: float) -> None:
        super().advance_to(t)
        self._follow_truth()

    def _follow_truth(self) -> None:
        """The newest ground truth into the mirror (positions, velocities, kinematics for the video)."""
        samples = self._truth.take(N=8)
        if not samples:
            return
        newest = samples[-1]
        self.mirror.mirror(np.asarray(newest.qpos), np.asarray(newest.qvel), newest.time)
        self.truth_time = newest.time

    def truth(self) -> RobotState:
        return self.mirror.read()

    def truth_contacts(self) -> tuple[bool, bool] | None:
        return self.mirror.foot_contacts() if self.truth_time is not None else None

    def has_fallen(self) -> bool:
        return self.truth_time is not None and self.mirror.has_fallen()

    def report(self) -> dict[str, Any]:
        """The host's counters; once closed, the robot process's too, with its audit of every command it took (`wire`)."""
        robot = dict(self.robot_process.stop()) if self._closed else {"pid": self.robot_process.pid}
        wire = robot.pop("wire", None)
        return {**super().report(), "domain": self.domain.domain, "robot_process": robot} | ({"wire": wire} if wire is not None else {})

    _closed = False

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            super().close()
        finally:
            self.robot_process.stop()
            self._truth_session.close()
            self.domain.release()


def _dds_config(plan: RunPlan) -> tuple[DdsHardwareConfig, str]:
    if not isinstance(plan.hardware, DdsHardwareConfig) or plan.hardware_name is None:
        raise TypeError(f"a G1 over DDS needs a DDS config, the plan has {type(plan.hardware).__name__}")
    return plan.hardware, plan.hardware_name


def build_real_dds(plan: RunPlan, assets: Assets, stack: ExitStack) -> BuiltBackend:
    """The registry's `real-dds`: the robot on the config's network, its joint limits from the config (no MuJoCo)."""
    hardware, name = _dds_config(plan)
    clock = RunClock()
    backend = stack.enter_context(RealDdsBackend(DdsRobot(hardware, clock=clock.now), name, clock))
    limits = np.array([hardware.joints[joint].position_limits for joint in g1.JOINT_NAMES])
    return BuiltBackend(backend, None, (limits[:, 0], limits[:, 1]), remote_dds=hardware.dds)


def build_simulated_dds(plan: RunPlan, assets: Assets, stack: ExitStack) -> BuiltBackend:
    """The registry's `simulated-dds`: `g1ctl robot --dds` started on a domain of this run's own, the run's model its mirror."""
    from controller.runtime.sim_backends import simulated_world  # noqa: PLC0415 - MuJoCo, for the mirror

    hardware, name = _dds_config(plan)
    world = simulated_world(plan, assets, stack)
    remote = ("--remote", plan.scenario_name) if plan.input == "unitree-remote" else ()  # the robot's remote plays the scenario
    drills = tuple(arg for fault in (plan.faults.robot if plan.faults is not None else ()) for arg in ("--fault", fault))
    robot_args = (*remote, *drills, "--joint-map", name, "--seed", str(plan.seed))
    backend = stack.enter_context(SimulatedDdsBackend(world, hardware, name, plan.assets_dir, robot_args))
    return BuiltBackend(backend, world, world.joint_limits(), remote_dds=backend.host.cfg.dds)  # on the domain it claimed
