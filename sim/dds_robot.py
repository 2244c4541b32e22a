"""A simulated G1 in its own process that speaks the robot's DDS protocol: `g1ctl robot --dds`.

MuJoCo physics with the G1's PD servos behind the emulated low-level controller
(`hw.emulation.g1_lowlevel`), paced to the wall clock: every `period_s` it takes the
`LowCmd_`s that arrived on `rt/lowcmd`, steps the physics to the wall time, and publishes a
`LowState_` on `rt/lowstate` (the remote's bytes included). Like the robot it starts limp and
goes limp on a bad command or a command gap. It stops after `duration_s` or on SIGTERM/SIGINT,
and reports what it counted.
"""

from __future__ import annotations

import signal
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any

from hw.dds.session import DdsConfig
from hw.emulation.g1_lowlevel import LowLevelConfig


@dataclass(frozen=True)
class DdsRobotConfig:
    mjcf: Path  # the G1 model (the assets' g1_mjcf)
    dds: DdsConfig = field(default_factory=DdsConfig)
    lowlevel: LowLevelConfig = field(default_factory=LowLevelConfig)
    period_s: float = 0.002  # LowState_ every 2 ms, as the robot publishes it
    duration_s: float | None = None  # None: until stopped


def run_dds_robot(cfg: DdsRobotConfig) -> dict[str, Any]:
    """Serve the simulated robot until the duration ends or a stop signal comes; the counters as a report."""
    from hw.dds import cdr, messages  # noqa: PLC0415 - MuJoCo and cyclonedds only here
    from hw.dds.session import DdsSession  # noqa: PLC0415
    from hw.emulation.g1_lowlevel import G1LowLevel  # noqa: PLC0415
    from hw.protocols.crc import FrameError  # noqa: PLC0415
    from sim.hardware_twin import MuJoCoPlant  # noqa: PLC0415
    from sim.robot import SimRobot  # noqa: PLC0415
    from sim.world import build_model  # noqa: PLC0415

    stop = {"requested": False}

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop["requested"] = True

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    robot = SimRobot(build_model(cfg.mjcf))
    session = DdsSession(cfg.dds)
    published = bad_frames = 0
    try:
        plant = MuJoCoPlant(robot)
        lowlevel = G1LowLevel(plant, cfg.lowlevel)
        commands = session.reader(cfg.dds.lowcmd_topic, messages.LowCmd_)
        states = session.writer(cfg.dds.lowstate_topic, messages.LowState_)
        start = time.monotonic()
        next_tick = start
        while not stop["requested"] and (cfg.duration_s is None or time.monotonic() - start < cfg.duration_s):
            now = plant.time()
            for data in DdsSession.take_cdr(commands):
                try:
                    lowlevel.receive(cdr.low_cmd_from_cdr(data), now)
                except FrameError:
                    bad_frames += 1
            lowlevel.tick(now)
            target = time.monotonic() - start
            while plant.time() < target:  # physics keeps up with the wall clock
                plant.step()
            DdsSession.write_cdr(states, cdr.low_state_to_cdr(lowlevel.low_state()))
            published += 1
            next_tick += cfg.period_s
            time.sleep(max(0.0, next_tick - time.monotonic()))
        counters = lowlevel.counters
        return {
            "states_published": published, "commands": counters.commands, "crc_errors": counters.crc_errors, "bad_frames": bad_frames,
            "mode_machine_mismatches": counters.mode_machine_mismatches, "timeouts": counters.timeouts,
            "sim_seconds": round(plant.time(), 3), "limp": lowlevel.limp, "limp_reason": lowlevel.limp_reason,
        }  # fmt: skip
    finally:
        session.close()
        robot.close()
        for s, handler in previous.items():
            signal.signal(s, handler)
