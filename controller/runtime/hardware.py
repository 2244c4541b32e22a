"""Open a hardware config for bring-up: real buses, or simulated hardware with MuJoCo behind it.

`open_hardware` yields a configured `HardwareRobot` and a `pump` that runs one bus cycle:
paced at the config's `cycle_hz` on the wall clock for real hardware, and for the bus robot in
its own process (`robot_process: true`: `g1ctl robot --buses --gantry` started, its ports opened
as a real robot's); for a config marked `simulated`, one physics step of the G1 hanging in a
virtual gantry (MuJoCo is imported only then).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager

from controller.runtime.loop import WallClock
from hw.hardware_robot import HardwareRobot
from hw.jointmap import load_hardware_config

GANTRY_HEIGHT_M = 0.25


@contextmanager
def open_hardware(name: str, assets_dir: str | None = None, require_all: bool = True) -> Iterator[tuple[HardwareRobot, Callable[[], None]]]:
    cfg = load_hardware_config(name)
    with ExitStack() as stack:
        if cfg.robot_process:
            from controller.runtime.bus_process import BusRobotProcess, host_config  # noqa: PLC0415

            robot_process = BusRobotProcess(name, assets_dir, extra_args=("--gantry",))
            stack.callback(robot_process.stop)
            cfg = host_config(cfg, robot_process.ports)
        if cfg.simulated and not cfg.robot_process:
            from controller.assets import ensure_assets  # noqa: PLC0415
            from hw.emulation.rig import SimulatedHardware  # noqa: PLC0415
            from sim.hardware_twin import MuJoCoPlant  # noqa: PLC0415 - MuJoCo only for simulated hardware
            from sim.robot import SimRobot  # noqa: PLC0415
            from sim.world import build_model  # noqa: PLC0415

            robot = stack.enter_context(SimRobot(build_model(ensure_assets(assets_dir, quiet=True).g1_mjcf)))
            plant = MuJoCoPlant(robot, gantry_height=GANTRY_HEIGHT_M)
            rig = stack.enter_context(SimulatedHardware(cfg, plant))
            host = stack.enter_context(HardwareRobot(rig.host_config, stamp_clock=plant.time, await_replies=rig.await_replies))

            def pump() -> None:
                host.cycle()
                rig.step()

            host.configure(require_all=require_all)
            rig.step()
        else:
            host = stack.enter_context(HardwareRobot(cfg))
            clock = WallClock()
            deadline = [clock.now()]

            def pump() -> None:
                host.cycle()
                deadline[0] = max(deadline[0] + 1.0 / cfg.cycle_hz, clock.now())
                clock.sleep_until(deadline[0])

            host.configure(require_all=require_all)
        yield host, pump
