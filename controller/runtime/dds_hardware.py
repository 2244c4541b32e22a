"""Open a G1 over DDS for bring-up: the real robot, or the simulated one started here on a virtual gantry.

`open_dds_hardware` yields a configured `DdsRobot` (its first `LowState_` in, the high-level
motion service released) and a `pump` that runs one `cycle()` paced at 500 Hz on the wall
clock. A `simulated: true` config first starts `g1ctl robot --dds --gantry` in a child
process (so a sweep cannot tip it over); the robot is closed (damped) and then the process
stopped on every exit path.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager

from controller.runtime.dds_backend import SIM_SOFT_START_S, RobotProcess
from controller.runtime.loop import WallClock
from hw.dds.config import DdsHardwareConfig
from hw.dds.robot import DdsRobot
from hw.errors import ConfigError, HardwareFault
from hw.g1 import CONTROL_CYCLE_HZ
from hw.jointmap import load_robot_config


@contextmanager
def open_dds_hardware(
    name_or_cfg: str | DdsHardwareConfig, assets_dir: str | None = None, read_only: bool = False
) -> Iterator[tuple[DdsRobot, Callable[[], None]]]:
    """`read_only`: leave the robot's high-level motion service alone (scan, monitor, imu only listen: a G1
    standing on its own controller keeps standing); nothing is sent unless the caller activates or damps."""
    cfg = load_robot_config(name_or_cfg) if isinstance(name_or_cfg, str) else name_or_cfg
    if not isinstance(cfg, DdsHardwareConfig):
        raise ConfigError(f"hardware config '{name_or_cfg}' drives CAN/serial buses, not a G1 over DDS")
    if read_only:
        cfg = dataclasses.replace(cfg, release_motion_service=False)
    with ExitStack() as stack:
        process: RobotProcess | None = None
        if cfg.simulated:  # the simulated robot starts in its default pose: nothing to ramp
            cfg = dataclasses.replace(cfg, safety=dataclasses.replace(cfg.safety, soft_start_time=SIM_SOFT_START_S))
            process = RobotProcess(cfg, assets_dir, extra_args=("--gantry",))
            stack.callback(process.stop)  # registered first: runs after the robot is closed
        robot = stack.enter_context(DdsRobot(cfg))
        clock = WallClock()
        deadline = [clock.now()]

        def pump() -> None:
            robot.cycle()
            deadline[0] = max(deadline[0] + 1.0 / CONTROL_CYCLE_HZ, clock.now())
            clock.sleep_until(deadline[0])

        try:
            robot.configure()
        except HardwareFault as exc:
            if process is not None and process.process.poll() is not None:  # say why, not just that it is silent
                report = process.stop()
                raise HardwareFault(f"the simulated robot exited (code {report['exit_code']}): {report.get('stderr_tail')}") from exc
            raise
        yield robot, pump
