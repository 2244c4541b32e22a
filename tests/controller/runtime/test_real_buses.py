"""A robot on real buses (the registry's `real-buses`): cycles at the config's rate on the wall clock, and interfaces that
cannot be opened refused in one line before any motor is spoken to.

The "real" interfaces are real python-can and pyserial objects: python-can `virtual` channels and pseudo-terminals with
the firmware emulators at their far ends, in this process (the robot in its own process is test_bus_robot.py's).
"""

from __future__ import annotations

import dataclasses
import os
import re
import select
import tty
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial

from controller.runtime.hardware_backend import RealBusesBackend
from controller.runtime.loop import RunClock
from controller.runtime.run_config import RunConfig
from controller.runtime.run_plan import resolve_run
from hw import g1
from hw.emulation.plant import StaticPlant
from hw.emulation.rig import SimulatedHardware
from hw.errors import ConfigError
from hw.hardware_robot import HardwareRobot
from hw.jointmap import HardwareConfig, load_hardware_config
from hw.shipped import config_dir
from tests.conftest import g1ctl, one_line_error


def without_imu(cfg: HardwareConfig) -> HardwareConfig:
    """The emulated IMU writes a frame per physics step, and a wall-clock run has no physics here: leave it out."""
    imu = cfg.imu.bus if cfg.imu is not None else None
    return dataclasses.replace(cfg, imu=None, imu_model=None, buses={k: v for k, v in cfg.buses.items() if k != imu})


@pytest.mark.slow
def test_real_buses_cycle_at_the_configured_rate_on_the_wall_clock() -> None:
    cfg = without_imu(load_hardware_config("sim-mixed"))  # RS-485 on pseudo-terminals, CAN on virtual channels
    # RS-485 answered by emulator threads of this process is slow: with a 3 ms wait the ankles (last of six motors a
    # port) missed five replies in a row, and with 6 ms a cycle took 8 ms at the median (2026-12-02, a slow machine).
    # At 100 Hz with that wait a cycle ends inside its period, so the period measured is the pacer's alone.
    safety = dataclasses.replace(cfg.safety, soft_start_time=0.2, cycle_timeout=0.006)
    cfg = dataclasses.replace(cfg, cycle_hz=100.0, safety=safety)
    plant = StaticPlant(dict(zip(g1.JOINT_NAMES, g1.default_joint_vector(), strict=True)))
    with SimulatedHardware(cfg, plant) as rig:
        real = dataclasses.replace(rig.host_config, simulated=False)  # the emulators' interfaces, opened as a real robot's
        clock = RunClock()
        with RealBusesBackend(HardwareRobot(real, stamp_clock=clock.now), "mixed", real.cycle_hz, clock) as backend:
            backend.host.open()
            backend.start()  # the soft start, paced on the wall clock too
            start = backend.now()
            for tick in range(1, 51):  # one second of 50 Hz control ticks
                backend.advance_to(start + tick / 50)
                assert backend.now() >= start + tick / 50  # it returns at the tick's deadline, not before
                rig.step()  # the motors' own control step
            assert backend.fault() is None
        report = backend.report()
    period, pacer = report["cycle_period_ms"], backend.pacer
    assert report["rate_hz"] == 100.0 and period["target"] == 10.0
    assert abs(period["p50"] - 10.0) < 0.2, report  # on its grid: the median period is the target's however loaded
    # Every 10 ms slot from the first cycle to the last had a cycle or was counted as missed.
    slots = round(sum(pacer.periods) / pacer.period) + 1
    assert abs(pacer.cycles + pacer.missed - slots) <= 1 and report["missed_cycles"] == pacer.missed
    # Replies that miss a cycle happen here (emulator threads share this process), never five in a row: no fault.
    assert pacer.cycles > 90 and report["faults"] == 0 and report["frames_received"] > 0 and report["state"] == "closed"


def a_real_robot_config(tmp_path: Path, buses: dict[str, str]) -> Path:
    """sim-mixed as a real robot's config (`simulated: false`), with some buses' lines replaced."""
    lines = (config_dir("hardware") / "sim-mixed.yaml").read_text().splitlines()
    text = "\n".join(line for line in lines if not line.startswith("imu_model:")).replace("simulated: true", "simulated: false")
    for name, line in buses.items():
        old = next(candidate for candidate in text.splitlines() if candidate.startswith(f"  {name}: "))
        text = text.replace(old, f"  {name}: {line}")
    path = tmp_path / "my-robot.yaml"
    path.write_text(text)
    return path


@pytest.fixture
def ports() -> Iterator[list[tuple[int, str]]]:
    """Two pseudo-terminals standing for RS-485 adapters: the test holds the motors' ends."""
    pairs = []
    for _ in range(2):
        master, slave = os.openpty()
        tty.setraw(slave)
        pairs.append((master, os.ttyname(slave), slave))
    try:
        yield [(master, path) for master, path, _ in pairs]
    finally:
        for master, _, slave in pairs:
            os.close(master)
            os.close(slave)


def nothing_arrived(fd: int) -> bool:
    return not select.select([fd], [], [], 0.05)[0]


@pytest.mark.slow
def test_an_interface_that_cannot_be_opened_is_refused_in_one_line_with_nothing_energized(
    tmp_path: Path, ports: list[tuple[int, str]]
) -> None:
    (left, left_path), (right, right_path) = ports
    cases = {  # the legs' ports open (they come first), then one bus cannot be
        "no such CAN adapter": (
            {"can0": "{kind: can, interface: slcan, channel: /dev/ttyACM-nope, bitrate: 1000000}"},
            r"cannot open CAN bus 'can0' \(slcan:/dev/ttyACM-nope\): cannot open slcan port /dev/ttyACM-nope: .*No such file",
        ),
        "no SocketCAN channel": (
            {"can1": "{kind: can, interface: socketcan, channel: nosuch0, bitrate: 1000000}"},
            r"cannot open CAN bus 'can1' \(socketcan:nosuch0\): ",
        ),
        "no serial device": (
            {"imu": "{kind: serial, port: /dev/ttyUSB-nope, baudrate: 921600}"},
            r"cannot open serial port 'imu' \(/dev/ttyUSB-nope\): .*No such file.*check the device path",
        ),
    }
    for what, (buses, expected) in cases.items():
        config = a_real_robot_config(tmp_path, {"rs485_left": f"{{kind: serial, port: {left_path}}}",
                                                "rs485_right": f"{{kind: serial, port: {right_path}}}", **buses})  # fmt: skip
        line = one_line_error(g1ctl("run", "--hardware", str(config), "--input", "scripted", "--duration", "1"))
        assert re.match(f"g1ctl: error: {expected}", line), (what, line)
        assert nothing_arrived(left) and nothing_arrived(right), what  # no motor was spoken to
    holder = serial.Serial(right_path, exclusive=True)  # another program holds the right leg's adapter
    try:
        config = a_real_robot_config(tmp_path, {"rs485_left": f"{{kind: serial, port: {left_path}}}",
                                                "rs485_right": f"{{kind: serial, port: {right_path}}}"})  # fmt: skip
        line = one_line_error(g1ctl("run", "--hardware", str(config), "--input", "scripted", "--duration", "1"))
        assert line.startswith(f"g1ctl: error: cannot open serial port 'rs485_right' ({right_path}): ") and "lock" in line, line
        assert nothing_arrived(left)
    finally:
        holder.close()


def test_real_buses_take_real_time_scheduling_and_refuse_what_needs_a_simulator(tmp_path: Path) -> None:
    config = str(a_real_robot_config(tmp_path, {}))
    plan = resolve_run(RunConfig(hardware=config, input="scripted", rt_priority=50, cpu=0))
    assert plan.backend.name == "real-buses" and (plan.rt_priority, plan.cpu, plan.clock, plan.estimator) == (50, 0, "wall", True)
    for option, message in (({"video": Path("v.mp4")}, "--video: not on a real robot"), ({"faults": "nan-command"}, "--faults: not")):
        with pytest.raises(ConfigError, match=message):
            resolve_run(RunConfig(hardware=config, **option))  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="--rt-priority and --cpu are for a real robot's run"):
        resolve_run(RunConfig(hardware="sim-can-process", rt_priority=50))
