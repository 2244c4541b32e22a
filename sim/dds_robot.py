"""A simulated G1 in its own process that speaks the robot's DDS protocol: `g1ctl robot --dds`.

MuJoCo physics with the G1's PD servos behind the emulated low-level controller
(`hw.emulation.g1_lowlevel`), paced to the wall clock: every `period_s` it takes the `LowCmd_`s
that arrived on `rt/lowcmd`, steps the physics to the wall time, and publishes a `LowState_` on
`rt/lowstate`. Like the robot:

- It boots with a high-level mode active (`motion_mode`, "ai"): until a host releases it over
  `motion_switcher` (`hw.dds.motion_switcher`) every `LowCmd_` is refused and counted.
- It goes limp on a bad command or a command gap.

Unlike the robot, its physics waits for the first command it takes: the G1 stands still in its
default pose until then (the real one would stand under its own controller, or hang on a
gantry), so a host that takes seconds to start finds it standing. With `truth` it also
publishes its ground truth on `sim/truth` (for a run's metrics, `sim.dds_truth`); with
`lockstep` it answers every command at once with the newest state and steps one period of
physics per command, quiet in between but for a heartbeat state every 100 ms (the benchmark's
round trip); `faults` make it develop the faults of `hw.emulation.g1_faults` mid-run; `remote` fills
the `LowState_`'s `wireless_remote` (a scenario, the keyboard, a gamepad: `g1ctl robot --remote`).
Its IMU measures as the `joint_map` config's `imu_model` states (`hw.emulation.imu_model`; the
model's defaults without one), its noise seeded by `seed`.
It stops after `duration_s` or on SIGTERM/SIGINT and reports what it counted.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

from hw.dds.session import DdsConfig
from hw.emulation.g1_faults import RobotFault
from hw.emulation.g1_lowlevel import LowLevelConfig
from hw.g1 import CONTROL_CYCLE_HZ

if TYPE_CHECKING:
    from hw.dds.config import DdsHardwareConfig
    from hw.emulation.wire_audit import WireAudit

LOCKSTEP_SILENCE = 50  # periods without a command before a lock-step robot publishes on its own
TRUTH_EVERY = 5  # ticks between ground-truth samples (100 Hz at a 2 ms period)
GANTRY_HEIGHT_M = 0.25  # with `gantry`: the pelvis this far above standing (as `g1ctl hw` hangs simulated buses)


@dataclass(frozen=True)
class DdsRobotConfig:
    mjcf: Path  # the G1 model (the assets' g1_mjcf)
    dds: DdsConfig = field(default_factory=DdsConfig)
    lowlevel: LowLevelConfig = field(default_factory=LowLevelConfig)
    period_s: float = 1.0 / CONTROL_CYCLE_HZ  # a LowState_ every hardware cycle (2 ms), as the robot publishes it
    duration_s: float | None = None  # None: until stopped
    motion_mode: str = "ai"  # the high-level mode active at boot; "": released, low-level commands taken at once
    truth: bool = False  # publish the simulator's state on sim/truth
    lockstep: bool = False  # answer each LowCmd_ with a LowState_ at once (benchmarks)
    faults: tuple[RobotFault, ...] = ()
    remote: Callable[[float], bytes] | None = None  # wireless_remote's 40 bytes by the time since the first command; None: zeros
    gantry: bool = False  # hang the pelvis in a virtual gantry (bring-up: a sweep cannot tip it over)
    joint_map: str | None = None  # a DDS hardware config: every command taken is audited against its limits, the IMU is its imu_model
    seed: int = 0  # the IMU's noise (the run's seed, from the host that starts this robot)


def run_dds_robot(cfg: DdsRobotConfig) -> dict[str, Any]:
    """Serve the simulated robot until the duration ends or a stop signal comes; the counters as a report."""
    stop = {"requested": False}

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop["requested"] = True

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    server = _Server(cfg)
    try:
        start = time.monotonic()
        while not stop["requested"] and (cfg.duration_s is None or time.monotonic() - start < cfg.duration_s):
            server.tick()
        return server.report()
    finally:
        server.close()
        for s, handler in previous.items():
            signal.signal(s, handler)


def _load_joint_map(joint_map: str) -> DdsHardwareConfig:
    """The DDS hardware config the robot is started for (its joint limits, its IMU model)."""
    from hw.dds.config import DdsHardwareConfig  # noqa: PLC0415
    from hw.errors import ConfigError  # noqa: PLC0415
    from hw.jointmap import load_robot_config  # noqa: PLC0415

    cfg = load_robot_config(joint_map)
    if not isinstance(cfg, DdsHardwareConfig):
        raise ConfigError(f"--joint-map {joint_map}: a simulated G1 over DDS needs a DDS hardware config (transport: dds)")
    return cfg


def _audit(cfg: DdsHardwareConfig) -> WireAudit:
    """The audit of every command taken, against the joint limits of a DDS hardware config (times: simulated seconds)."""
    from hw import g1  # noqa: PLC0415
    from hw.emulation.wire_audit import WireAudit, WireLimits  # noqa: PLC0415

    return WireAudit(g1.JOINT_NAMES, WireLimits.of(g1.JOINT_NAMES, cfg.joints))


class _Server:
    """The robot's loop, one `tick()` per period (lock-step: per command, or per period without one)."""

    def __init__(self, cfg: DdsRobotConfig) -> None:
        from hw.dds import messages  # noqa: PLC0415 - MuJoCo and cyclonedds only here
        from hw.dds.motion_switcher import MotionSwitcherService  # noqa: PLC0415
        from hw.dds.session import DdsSession  # noqa: PLC0415
        from hw.emulation.g1_lowlevel import G1LowLevel  # noqa: PLC0415
        from hw.emulation.imu_model import ImuModel, ImuModelConfig  # noqa: PLC0415
        from sim.dds_truth import TRUTH_TOPIC, SimTruth_  # noqa: PLC0415
        from sim.hardware_twin import MuJoCoPlant  # noqa: PLC0415
        from sim.robot import SimRobot  # noqa: PLC0415
        from sim.world import build_model  # noqa: PLC0415

        self.cfg = cfg
        self.robot = SimRobot(build_model(cfg.mjcf))
        self.session = DdsSession(cfg.dds)
        self.plant = MuJoCoPlant(self.robot, gantry_height=GANTRY_HEIGHT_M if cfg.gantry else None)
        hardware = _load_joint_map(cfg.joint_map) if cfg.joint_map is not None else None
        self.audit = _audit(hardware) if hardware is not None else None
        imu = ImuModel(hardware.imu_model if hardware is not None and hardware.imu_model is not None else ImuModelConfig(), cfg.seed)
        self.lowlevel = G1LowLevel(self.plant, cfg.lowlevel, self.audit, imu)
        self.commands = self.session.reader(cfg.dds.lowcmd_topic, messages.LowCmd_)
        self.states = self.session.writer(cfg.dds.lowstate_topic, messages.LowState_)
        self.command_arrived = self.session.wait_set(self.commands)
        self.take_commands, self.write_state = DdsSession.cdr_taker(self.commands), DdsSession.cdr_writer(self.states)
        self.motion = MotionSwitcherService(self.session, cfg.motion_mode)
        self._truth_type = SimTruth_
        self.truth = self.session.writer(TRUTH_TOPIC, SimTruth_) if cfg.truth else None
        self.published = self.bad_frames = self.refused = self.ticks = 0
        self.physics_start: float | None = None  # wall time of the first command taken: the physics runs from then
        self.boot = self.next_tick = time.monotonic()
        self.faults_seen: set[str] = set()
        self.state_cdr = self._sample()

    def tick(self) -> None:
        from hw.dds import cdr  # noqa: PLC0415
        from hw.protocols.crc import FrameError  # noqa: PLC0415

        if self.cfg.lockstep:
            self.command_arrived(max(self.next_tick - time.monotonic(), 0.0))
        now = self.plant.time()
        self.motion.poll()  # under a microsecond when no request waits
        taken = self.take_commands()
        if taken and self.cfg.lockstep:
            self._publish()  # the state sampled before this command: a robot's sensors do not wait for the host
        for data in taken:
            if self.motion.mode:  # the high-level controller owns the motors: a host's command is refused
                self.refused += 1
                continue
            try:
                self.lowlevel.receive(cdr.low_cmd_from_cdr(data), now)
            except FrameError:
                self.bad_frames += 1
        if self.physics_start is None and self.lowlevel.counters.commands:
            self.physics_start = time.monotonic()
        self.lowlevel.tick(now)
        if self.physics_start is not None and not self.cfg.lockstep:
            target = time.monotonic() - self.physics_start
            while self.plant.time() < target:  # physics keeps up with the wall clock
                self.plant.step()
        elif self.physics_start is not None and taken:
            self.plant.step()  # lock-step: one period of physics per command, none while the host is silent
        if "exit" in self._faults():
            os._exit(3)  # the robot process dies: no report, no goodbye on the wire
        self.state_cdr = self._sample()
        if taken and self.cfg.lockstep:
            # On its own it publishes only after a silence of LOCKSTEP_SILENCE periods (a heartbeat for hosts connecting):
            # at one period its tick would race the host's next command (both 2 ms) and answer it late.
            self.next_tick = time.monotonic() + LOCKSTEP_SILENCE * self.cfg.period_s
            return
        self._publish()
        self.next_tick += self.cfg.period_s
        if not self.cfg.lockstep:
            time.sleep(max(0.0, self.next_tick - time.monotonic()))
        else:
            self.next_tick = time.monotonic() + LOCKSTEP_SILENCE * self.cfg.period_s

    def _faults(self) -> frozenset[str]:
        from hw.emulation.g1_faults import active  # noqa: PLC0415

        since = None if self.physics_start is None else time.monotonic() - self.physics_start
        kinds = active(self.cfg.faults, since)
        self.faults_seen |= kinds
        if "mode-machine" in kinds:
            self.lowlevel.mode_machine = (self.cfg.lowlevel.mode_machine + 1) & 0xFF
        return kinds

    def _sample(self) -> bytes | None:
        """The `LowState_` to publish now as CDR (None: a stale robot publishes nothing); truth on its own period."""
        from hw.dds import cdr  # noqa: PLC0415
        from hw.emulation.g1_faults import imu_fault, tamper  # noqa: PLC0415

        self.ticks += 1
        if self.truth is not None and self.ticks % TRUTH_EVERY == 0:
            data = self.robot.data
            self.truth.write(self._truth_type(float(data.time), data.qpos.tolist(), data.qvel.tolist()))
        kinds = self._faults()
        if "stale" in kinds:
            return None
        uptime = time.monotonic() - self.boot
        remote = bytes(40) if self.cfg.remote is None else self.cfg.remote(self._since_first_command())
        state = self.lowlevel.low_state(remote=remote, uptime_s=uptime, imu_fault=imu_fault(kinds))
        return cdr.low_state_to_cdr(tamper(state, kinds))

    def _since_first_command(self) -> float:
        """The remote's time line, like the faults': it starts with the host's first command taken (0 until then)."""
        return 0.0 if self.physics_start is None else time.monotonic() - self.physics_start

    def _publish(self) -> None:

        if self.state_cdr is not None:
            self.write_state(self.state_cdr)
            self.published += 1

    def report(self) -> dict[str, Any]:
        counters = self.lowlevel.counters
        return {
            "states_published": self.published, "commands": counters.commands, "crc_errors": counters.crc_errors,
            "bad_frames": self.bad_frames, "mode_machine_mismatches": counters.mode_machine_mismatches, "timeouts": counters.timeouts,
            "damping_commands": counters.damping_commands,
            "sim_seconds": round(self.plant.time(), 3), "limp": self.lowlevel.limp, "limp_reason": self.lowlevel.limp_reason,
            "motion_mode": self.motion.mode, "motion_release_requests": self.motion.counters.release_requests,
            "commands_while_high_level": self.refused, "faults": sorted(self.faults_seen),
        } | ({"wire": self.audit.report()} if self.audit is not None else {})  # fmt: skip

    def close(self) -> None:
        self.session.close()
        self.robot.close()
