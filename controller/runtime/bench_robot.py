"""Open a robot for a bench script from its hardware config: `open_robot`.

    from controller.runtime.bench_robot import open_robot

    with open_robot("sim-can") as robot:  # a shipped name, or a path to your own config
        print(robot.sweep("left_knee_joint", fraction=0.2))

`open_robot` yields a `hw.bench.BenchRobot` (scan, read, move, sweep, zero, damp, the IMU: see
hw/bench.py) and, however the block ends (an exception, Ctrl-C), damps and closes the robot
before anything else is stopped. The hardware config names the robot (`robot_kind`, as a run's
does), and `OPENERS` holds how each kind is opened:

- real buses: the config's CAN interfaces and serial ports, cycles paced at 500 Hz on the wall clock;
- simulated buses (sim-can, sim-mixed): firmware emulators with the G1 in MuJoCo behind them, in
  this process, hanging in a virtual gantry; one cycle per physics step, as fast as it goes;
- a real G1 over DDS: the robot on the config's network, opened listening only;
- the simulated G1 over DDS (sim-dds): `g1ctl robot --dds --gantry` started in a child process
  on a DDS domain of its own, stopped after the robot is closed.

This module is in the controller, not in `hw/`, because a simulated robot needs what `hw/` may
not import: MuJoCo (`sim/`), the G1's model from the assets, and the robot process of a run.
A bus or DDS config that cannot be opened is refused in one line naming the bus (or domain)
and the reason, with nothing energized.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from typing import TYPE_CHECKING

from controller.runtime.backend_registry import RobotConfig, robot_kind
from controller.runtime.loop import WallClock
from hw.bench import BenchRobot, Pump
from hw.bus_bench import BusBenchRobot
from hw.dds.config import DdsHardwareConfig
from hw.errors import ConfigError, HardwareFault
from hw.g1 import CONTROL_CYCLE_HZ
from hw.hardware_robot import HardwareRobot
from hw.jointmap import HardwareConfig, load_robot_config

if TYPE_CHECKING:
    from hw.dds.robot import DdsRobot

GANTRY_HEIGHT_M = 0.25  # the simulated robot hangs this far above its standing height
# The simulated G1 is a Python process stepping MuJoCo on the wall clock: on a loaded machine its LowState_s can pause
# for longer than a real robot's 50 ms timeout, which would latch a fault mid-sweep on a robot that is only late.
SIMULATED_STATE_TIMEOUT_S = 0.25

Opener = Callable[[RobotConfig, str, str | None, ExitStack], BenchRobot]


@contextmanager
def open_robot(hardware: str, assets_dir: str | None = None) -> Iterator[BenchRobot]:
    """The robot of hardware config `hardware` (a shipped name or a path), opened and configured: every bus and
    port open (motors that do not answer are reported by `scan()`, and refused by a move), or the G1's first state
    in. `assets_dir`: where the G1's model is cached, for a simulated robot (default: the usual cache)."""
    cfg = load_robot_config(hardware)
    kind = robot_kind(cfg)
    if kind not in OPENERS:
        raise ConfigError(
            f"hardware config '{hardware}' names a {kind} robot, which the bench cannot open (it opens: {', '.join(OPENERS)})"
        )
    with ExitStack() as stack:
        yield OPENERS[kind](cfg, hardware, assets_dir, stack)


def paced(cycle: Callable[[], None], rate_hz: float) -> Pump:
    """`cycle` held to `rate_hz` on the wall clock; a late cycle re-anchors the schedule rather than bursting."""
    clock = WallClock()
    deadline = clock.now()

    def pump() -> None:
        nonlocal deadline
        cycle()
        deadline = max(deadline + 1.0 / rate_hz, clock.now())
        clock.sleep_until(deadline)

    return pump


def _bus_config(cfg: RobotConfig) -> HardwareConfig:
    if not isinstance(cfg, HardwareConfig):
        raise TypeError(f"a robot on buses needs a bus config, got {type(cfg).__name__}")
    return cfg


def _dds_config(cfg: RobotConfig) -> DdsHardwareConfig:
    if not isinstance(cfg, DdsHardwareConfig):
        raise TypeError(f"a G1 over DDS needs a DDS config, got {type(cfg).__name__}")
    return cfg


def open_real_buses(cfg: RobotConfig, name: str, assets_dir: str | None, stack: ExitStack) -> BenchRobot:
    bus_cfg = _bus_config(cfg)
    host = stack.enter_context(HardwareRobot(bus_cfg))
    host.configure(require_all=False)
    return BusBenchRobot(host, paced(host.cycle, bus_cfg.cycle_hz), name)


def open_bus_robot_process(cfg: RobotConfig, name: str, assets_dir: str | None, stack: ExitStack) -> BenchRobot:
    """`g1ctl robot --buses --gantry` in its own process (a sweep cannot tip it over), its ports opened as a real robot's;
    the process is stopped after the robot is closed (damped)."""
    from controller.runtime.bus_process import BusRobotProcess, host_config  # noqa: PLC0415

    process = BusRobotProcess(name, assets_dir, extra_args=("--gantry",))
    stack.callback(process.stop)
    return open_real_buses(host_config(_bus_config(cfg), process.ports), name, assets_dir, stack)


def open_simulated_buses(cfg: RobotConfig, name: str, assets_dir: str | None, stack: ExitStack) -> BenchRobot:
    from controller.assets import ensure_assets  # noqa: PLC0415
    from controller.runtime.sim_backends import SIM_CYCLE_TIMEOUT_S, SIM_SOFT_START_S  # noqa: PLC0415
    from hw.emulation.rig import SimulatedHardware  # noqa: PLC0415
    from sim.hardware_twin import MuJoCoPlant  # noqa: PLC0415 - MuJoCo only for simulated hardware
    from sim.robot import SimRobot  # noqa: PLC0415
    from sim.world import build_model  # noqa: PLC0415

    sim = stack.enter_context(SimRobot(build_model(ensure_assets(assets_dir, quiet=True).g1_mjcf)))
    plant = MuJoCoPlant(sim, gantry_height=GANTRY_HEIGHT_M)
    bus_cfg = _bus_config(cfg)  # timed as a simulated run's: emulators may answer later in wall time than motors do
    safety = dataclasses.replace(bus_cfg.safety, soft_start_time=SIM_SOFT_START_S, cycle_timeout=SIM_CYCLE_TIMEOUT_S)
    bus_cfg = dataclasses.replace(bus_cfg, safety=safety)
    rig = stack.enter_context(SimulatedHardware(bus_cfg, plant))
    host = HardwareRobot(rig.host_config, stamp_clock=plant.time, await_replies=rig.await_replies)

    def pump() -> None:
        host.cycle()
        rig.step()

    robot = BusBenchRobot(host, pump, name)

    def keep_wire_report() -> None:  # once the robot is closed, before the emulators stop
        rig.step()  # the motors act on the last frames the host sent (its damping, then motor mode off)
        robot.wire_report = rig.audit.report()

    stack.callback(keep_wire_report)
    stack.enter_context(host)
    host.configure(require_all=False)
    rig.step()
    return robot


def open_real_dds(cfg: RobotConfig, name: str, assets_dir: str | None, stack: ExitStack) -> BenchRobot:
    g1, robot = _dds_robot(_dds_config(cfg), name)
    stack.enter_context(g1)
    g1.configure()
    return robot


def open_simulated_dds(cfg: RobotConfig, name: str, assets_dir: str | None, stack: ExitStack) -> BenchRobot:
    """`g1ctl robot --dds --gantry` (a sweep cannot tip it over) on a DDS domain of its own, timed as a simulated run's;
    the process is stopped after the robot is closed."""
    from controller.runtime.dds_backend import SIM_SOFT_START_S, RobotProcess  # noqa: PLC0415 - cyclonedds only for a DDS config
    from hw.dds.domains import claim_domain  # noqa: PLC0415

    dds_cfg = _dds_config(cfg)
    domain = claim_domain(dds_cfg.dds.domain)
    stack.callback(domain.release)
    dds_cfg = dataclasses.replace(
        dds_cfg,
        dds=dataclasses.replace(dds_cfg.dds, domain=domain.domain),
        safety=dataclasses.replace(dds_cfg.safety, soft_start_time=SIM_SOFT_START_S, state_timeout=SIMULATED_STATE_TIMEOUT_S),
    )
    # The config's joint limits judge what the robot takes (its wire report), and its imu_model is how its IMU measures.
    process = RobotProcess(dds_cfg, assets_dir, extra_args=("--gantry", "--joint-map", name), truth=False)
    stack.callback(process.stop)
    g1, robot = _dds_robot(dds_cfg, name)

    def keep_wire_report() -> None:  # once the robot is closed: the robot process's own audit of what it took
        robot.wire_report = process.stop().get("wire")

    stack.callback(keep_wire_report)
    stack.enter_context(g1)
    try:
        g1.configure()
    except HardwareFault as exc:
        if process.process.poll() is not None:  # say why, not just that it is silent
            report = process.stop()
            raise HardwareFault(f"the simulated robot exited (code {report['exit_code']}): {report.get('stderr_tail')}") from exc
        raise
    return robot


def _dds_robot(cfg: DdsHardwareConfig, name: str) -> tuple[DdsRobot, BenchRobot]:
    """The robot, to configure listening only (its motion service is released at the first command), and its bench."""
    from hw.dds.bench import DdsBenchRobot  # noqa: PLC0415 - cyclonedds only for a DDS config (the g1 extra)
    from hw.dds.robot import DdsRobot  # noqa: PLC0415

    g1 = DdsRobot(dataclasses.replace(cfg, release_motion_service=False))
    return g1, DdsBenchRobot(g1, paced(g1.cycle, CONTROL_CYCLE_HZ), name, cfg.release_motion_service)


# How each kind of robot (`robot_kind`) is opened.
OPENERS: dict[str, Opener] = {
    "real-buses": open_real_buses,
    "simulated-buses": open_simulated_buses,
    "simulated-buses-process": open_bus_robot_process,
    "real-dds": open_real_dds,
    "simulated-dds": open_simulated_dds,
}
