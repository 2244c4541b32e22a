"""The bus robot in its own process as a run backend: `g1ctl robot --buses` started, its ports opened as a real robot's.

`BusRobotProcess` starts `g1ctl robot --buses CONFIG` (MuJoCo and the firmware emulators, `sim/bus_robot.py`)
and reads where it put its ports from its first line; `host_config` is the config with those paths, which
`HardwareRobot` opens with the code a real robot's config gets (slcan, pyserial). `BusProcessBackend`
drives it like real buses (`PacedBusBackend`: cycles at the config's `cycle_hz` on the wall clock, late
ones counted) and mirrors the robot's ground truth (datagrams on a UNIX socket) into the run's own copy of
the model, for the metrics, fall detection and a video, as the simulated G1 over DDS does. A robot
process that dies or stops answering latches a fault like any bus (its ports hang up, or its replies go
stale), and the fault names the process. The process is stopped, and its counters and wire audit kept,
on every exit path. `build_bus_robot_process` makes it for the registry's `simulated-buses-process`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import select
import signal
import socket
import subprocess
import sys
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from controller.runtime.backend_registry import BuiltBackend
from controller.runtime.hardware_backend import PacedBusBackend, bus_config
from controller.runtime.loop import RunClock
from hw import g1
from hw.emulation.faulty_commands import FaultyCommands
from hw.errors import HardwareFault
from hw.hardware_robot import HardwareRobot
from hw.jointmap import HardwareConfig
from hw.robot import RobotInterface
from hw.types import RobotState

if TYPE_CHECKING:
    from controller.assets import Assets
    from controller.runtime.run_plan import RunPlan
    from hw.emulation.faults import FaultFile
    from sim.robot import SimRobot

READY_TIMEOUT_S = 60.0  # the robot process loads MuJoCo first: seconds on a cold, busy machine
STOP_TIMEOUT_S = 10.0
# A robot process that is alive has stopped answering when its newest ground truth (sent every 10 ms) is this old: at all,
# or when every motor fell silent at once. Its age is measured on the send stamp, so a host held back itself is not fooled.
STOPPED_AFTER_S = 0.1
SILENT_AFTER_S = 0.015
# A robot process killed is reaped only once the kernel has unmapped its memory (MuJoCo's): 50-70 ms after it went silent
# on a slow 2-core machine. A silent process is given this long to end before it is called stopped rather than dead.
EXIT_GRACE_S = 0.5
WATCH_AFTER_CLOSE_S = 0.05  # the robot's motors take the host's last frames (damping, motor mode off) before it stops
TRUTH_SIZE = 2 + g1.QPOS_SIZE + g1.QVEL_SIZE  # when it was sent (the machine's monotonic clock), time, qpos, qvel (float64)


class BusRobotProcess:
    """`g1ctl robot --buses CONFIG` as a child process: started, its ports read from its first line, stopped with SIGTERM."""

    def __init__(
        self, hardware: str, assets_dir: str | None = None, faults: str | None = None, seed: int = 0, truth_socket: Path | None = None,
        extra_args: tuple[str, ...] = (), ready_timeout: float = READY_TIMEOUT_S,
    ) -> None:  # fmt: skip
        command = [sys.executable, "-m", "controller.cli"]
        if assets_dir is not None:
            command += ["--assets-dir", assets_dir]
        command += ["robot", "--buses", hardware, "--seed", str(seed), *extra_args]
        if faults is not None:
            command += ["--faults", faults]
        if truth_socket is not None:
            command += ["--truth-socket", str(truth_socket)]
        self._stderr = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 - open for the child's lifetime, closed in stop()
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=self._stderr, env={**os.environ, "PYTHONUNBUFFERED": "1"}, text=True
        )
        self.report: dict[str, Any] | None = None
        try:
            ready = self._first_line(ready_timeout)
        except Exception:
            self.stop()
            raise
        self.ports: dict[str, str] = ready["buses"]

    @property
    def pid(self) -> int:
        return self.process.pid

    def _first_line(self, timeout: float) -> dict[str, Any]:
        """The robot's announcement of its ports; a robot that exits or stays silent first is a HardwareFault saying why."""
        stdout = self.process.stdout
        assert stdout is not None
        deadline = time.monotonic() + timeout
        while True:
            if not select.select([stdout], [], [], max(deadline - time.monotonic(), 0.0))[0]:
                raise HardwareFault(f"the robot process (g1ctl robot --buses, pid {self.pid}) was not ready within {timeout:g} s")
            line = stdout.readline()
            if not line:
                break  # it ended
            try:
                announced = json.loads(line)
            except json.JSONDecodeError:
                continue  # something else it printed first
            if isinstance(announced, dict) and announced.get("ready"):
                return announced
        self.stop()
        tail = "; ".join(self.report.get("stderr_tail", [])) if self.report else ""
        raise HardwareFault(f"the robot process (g1ctl robot --buses) ended before it was ready ({self.ended()}): {tail or 'no message'}")

    def ended(self, within: float = 0.0) -> str | None:
        """How the process ended ("exit code 3", "killed by SIGKILL"); None while it runs (after waiting `within` s)."""
        try:
            code = self.process.wait(within) if within > 0 else self.process.poll()
        except subprocess.TimeoutExpired:
            code = None
        if code is None:
            return None
        return f"killed by {signal.Signals(-code).name}" if code < 0 else f"exit code {code}"

    def stop(self) -> dict[str, Any]:
        """SIGTERM, wait, and what the robot counted (or how it ended, when it died)."""
        if self.report is not None:
            return self.report
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            self.process.send_signal(signal.SIGCONT)  # a stopped process takes its SIGTERM only once it runs again
        try:
            code = self.process.wait(STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.process.kill()
            code = self.process.wait()
        assert self.process.stdout is not None
        out = self.process.stdout.read()
        self.process.stdout.close()
        self._stderr.seek(0)
        err = self._stderr.read()
        self._stderr.close()
        lines = [line for line in out.strip().splitlines() if line.startswith("{")]
        try:
            counters = json.loads(lines[-1]) if lines and not json.loads(lines[-1]).get("ready") else {}
        except json.JSONDecodeError:
            counters = {}
        self.report = {"pid": self.process.pid, "exit_code": code, **counters}
        if code != 0:
            self.report["stderr_tail"] = err.strip().splitlines()[-3:]
        return self.report


class BusProcessBackend(PacedBusBackend):
    """The bus robot in its own process, driven over its pseudo-terminals; `mirror` (the run's copy of the model) follows
    its ground truth."""

    def __init__(
        self, mirror: SimRobot, cfg: HardwareConfig, config_name: str, assets_dir: str | None = None, faults: FaultFile | None = None,
        faults_name: str | None = None, seed: int = 0,
    ) -> None:  # fmt: skip
        """`faults`: a drill; its bus faults are the robot process's (`faults_name`, loaded there), its host faults (the
        controller's commands going bad) are this process's, on the robot's clock (from the start of the soft start)."""
        self.mirror = mirror
        self._dir = tempfile.TemporaryDirectory(prefix="g1ctl-bus-robot-")
        self._truth_path = Path(self._dir.name) / "truth.sock"
        self._truth = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self._truth.bind(str(self._truth_path))
        self._truth.setblocking(False)
        bus_faults = faults_name if faults is not None and faults.buses else None
        try:
            self.robot_process = BusRobotProcess(config_name, assets_dir, bus_faults, seed, self._truth_path)
        except Exception:
            self._release()
            raise
        clock = RunClock()
        try:
            host = HardwareRobot(host_config(cfg, self.robot_process.ports), stamp_clock=clock.now)
        except Exception:
            self.robot_process.stop()
            self._release()
            raise
        super().__init__(host, config_name, cfg.cycle_hz, clock)
        self.truth_time: float | None = None
        self._truth_sent: float | None = None  # when the robot sent its newest ground truth (the machine's monotonic clock)
        self._soft_start: float | None = None  # run time the robot's physics clock counts from (about)
        self._trouble: str | None = None  # why the robot process is not there to answer, once found
        if faults is not None and faults.host.start_s is not None:
            self.robot: RobotInterface = FaultyCommands(host, faults.host, self._robot_time)

    def _robot_time(self) -> float:
        """The robot's clock, which its physics and drills run on: from the first command that held a joint."""
        return self.now() - self._soft_start if self._soft_start is not None else 0.0

    def _configured(self) -> None:
        self._soft_start = self.now()

    def advance_to(self, t: float) -> None:
        super().advance_to(t)
        self._follow_truth()

    def _follow_truth(self) -> None:
        """The newest ground truth into the mirror."""
        newest = None
        while True:
            try:
                newest = self._truth.recv(8 * TRUTH_SIZE + 1)
            except (BlockingIOError, InterruptedError):
                break
        if newest is None or len(newest) != 8 * TRUTH_SIZE:
            return
        sample = np.frombuffer(newest, dtype=np.float64)
        qpos, qvel = sample[2 : 2 + g1.QPOS_SIZE], sample[2 + g1.QPOS_SIZE :]
        self.mirror.mirror(qpos, qvel, float(sample[1]))
        self._truth_sent, self.truth_time = float(sample[0]), float(sample[1])

    def truth(self) -> RobotState:
        return self.mirror.read()

    def truth_contacts(self) -> tuple[bool, bool] | None:
        return self.mirror.foot_contacts() if self.truth_time is not None else None

    def has_fallen(self) -> bool:
        return self.truth_time is not None and self.mirror.has_fallen()

    def fault(self) -> str | None:
        """The latched fault, the robot process named first when it died or stopped answering."""
        fault = super().fault()
        if fault is None:
            return None
        return f"{cause}; {fault}" if (cause := self.process_trouble()) else fault

    def process_trouble(self) -> str | None:
        """Why the robot process is not there to answer, if it is not: it ended, or it is alive and silent. Once found,
        the cause is kept: a silent process was given `EXIT_GRACE_S` to end, so the wait is paid once."""
        if self._trouble is not None:
            return self._trouble
        name = f"the robot process (g1ctl robot --buses, pid {self.robot_process.pid})"
        ended = self.robot_process.ended()
        if ended is None:
            self._follow_truth()
            silent_s = time.monotonic() - self._truth_sent if self._truth_sent is not None else 0.0
            if not (silent_s > STOPPED_AFTER_S or (silent_s > SILENT_AFTER_S and (self.host.store.missed > 0).all())):
                return None
            ended = self.robot_process.ended(within=EXIT_GRACE_S)
            if ended is None:
                self._trouble = f"{name} stopped answering (no ground truth for {1e3 * silent_s:.0f} ms)"
                return self._trouble
        self._trouble = f"{name} died ({ended})"
        return self._trouble

    def report(self) -> dict[str, Any]:
        """The host's counters; once closed, the robot process's too, with its audit of every command its motors took."""
        robot = dict(self.robot_process.stop()) if self._closed else {"pid": self.robot_process.pid}
        wire = robot.pop("wire", None)
        return {**super().report(), "robot_process": robot} | ({"wire": wire} if wire is not None else {})

    _closed = False

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            if isinstance(self.robot, FaultyCommands):
                self.robot.close()
            super().close()  # damps, then motor mode off
            if self.robot_process.ended() is None:
                time.sleep(WATCH_AFTER_CLOSE_S)
        finally:
            self.robot_process.stop()
            self._release()

    def _release(self) -> None:
        with contextlib.suppress(OSError):
            self._truth.close()
        self._dir.cleanup()


def host_config(cfg: HardwareConfig, ports: dict[str, str]) -> HardwareConfig:
    """`cfg` with the robot process's ports: what the host opens, as it would a real robot's adapters and serial ports."""
    buses = {
        name: dataclasses.replace(bus, channel=ports[name]) if bus.kind == "can" else dataclasses.replace(bus, port=ports[name])
        for name, bus in cfg.buses.items()
    }
    return dataclasses.replace(cfg, buses=buses)


def build_bus_robot_process(plan: RunPlan, assets: Assets, stack: ExitStack) -> BuiltBackend:
    """The registry's `simulated-buses-process`: `g1ctl robot --buses` started with the plan's config, fault plan and seed."""
    from controller.runtime.sim_backends import simulated_world  # noqa: PLC0415 - MuJoCo, for the mirror

    hardware, name = bus_config(plan)
    world = simulated_world(plan, assets, stack)
    backend = stack.enter_context(BusProcessBackend(world, hardware, name, plan.assets_dir, plan.faults, plan.faults_name, plan.seed))
    backend.host.open()
    return BuiltBackend(backend, world, world.joint_limits())
