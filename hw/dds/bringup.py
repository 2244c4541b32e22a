"""Bench bring-up on a G1 over DDS (`DdsRobot`): scan, monitor, sweep, damp, IMU.

The robot's main board reports every motor in each `LowState_`, so a scan is the newest state
read as a table; the sweep is the bus robot's (`hw.bringup.sweep_joint`) with the torque the
robot estimates. There is no `zero`: the G1's `LowCmd_` has no encoder-zero command. Each
operation takes a `pump` that runs one 500 Hz `cycle()` and paces it.
"""

from __future__ import annotations

import math
from typing import Any

from hw.bringup import Pump, SweepResult, sweep_joint
from hw.dds.robot import DdsRobot
from hw.errors import HardwareFault
from hw.g1 import CONTROL_CYCLE_HZ

SCAN_COLUMNS = ("joint", "slot", "temperature", "voltage", "error", "mode", "q")
MONITOR_COLUMNS = ("joint", "q", "dq", "tau", "temp", "error", "age_ms")


def scan_rows(robot: DdsRobot) -> list[dict[str, Any]]:
    """Every joint as the robot last reported it; `healthy` is False on error bits or over-temperature."""
    hot = robot.cfg.safety.max_temperature
    return [
        {
            "joint": j.name,
            "slot": slot,
            "temperature": j.temperature,
            "voltage": j.voltage,
            "error": f"{j.error_bits:#010x}",
            "mode": j.mode,
            "q": round(j.q, 4),
            "healthy": j.error_bits == 0 and j.temperature <= hot,
        }
        for slot, j in enumerate(robot.joints())
    ]


def monitor_rows(robot: DdsRobot) -> list[dict[str, Any]]:
    age_ms = round(1e3 * robot.state_age(), 1)  # one LowState_ carries every joint: one age
    return [
        {"joint": j.name, "q": j.q, "dq": j.dq, "tau": j.tau, "temp": j.temperature, "error": f"{j.error_bits:#x}", "age_ms": age_ms}
        for j in robot.joints()
    ]


def sweep(
    robot: DdsRobot,
    joint_name: str,
    pump: Pump,
    fraction: float = 0.3,
    speed: float = 0.3,
    torque_fraction: float = 0.3,
    max_tracking_error: float = 0.25,
) -> SweepResult:
    """`hw.bringup.sweep_joint` with the robot's torque estimate (`tau_est`) of the swept joint."""

    def torque() -> float:  # called only once sweep_joint has checked the name
        return robot.joints()[robot.joint_names.index(joint_name)].tau

    return sweep_joint(robot, robot.cfg.joints, joint_name, torque, pump, fraction, speed, torque_fraction, max_tracking_error)


def damp(robot: DdsRobot, pump: Pump, seconds: float = 2.0) -> None:
    """Damping on every joint for `seconds`; the robot goes limp on its own once the commands stop."""
    robot.enter_damping("damping requested by 'g1ctl hw damp'")
    for _ in range(max(int(seconds * CONTROL_CYCLE_HZ), 1)):
        pump()


def imu_summary(robot: DdsRobot, pump: Pump, seconds: float = 1.0) -> dict[str, Any]:
    """The IMU of the newest `LowState_` after `seconds` of cycles, with the states that came in meanwhile."""
    before, t0 = robot.counters(), robot.stamp_clock()
    received0, crc0 = before.states_received, before.crc_errors
    for _ in range(max(int(seconds * CONTROL_CYCLE_HZ), 1)):
        pump()
    after, elapsed = robot.counters(), robot.stamp_clock() - t0
    received = after.states_received - received0
    record = robot.low_state
    if record is None or received == 0:
        raise HardwareFault(f"no LowState_ from the robot in {seconds} s (DDS domain {robot.cfg.dds.domain}): is it still on?")
    imu = record["imu_state"]
    return {
        "quaternion_wxyz": [round(float(v), 5) for v in imu["quaternion"]],
        "rpy_deg": [round(math.degrees(float(v)), 2) for v in imu["rpy"]],
        "angular_velocity": [round(float(v), 4) for v in imu["gyroscope"]],
        "linear_acceleration": [round(float(v), 3) for v in imu["accelerometer"]],
        "imu_temperature": int(imu["temperature"]),
        "states_received": received,
        "crc_errors": after.crc_errors - crc0,
        "rate_hz": round(received / max(elapsed, 1e-9), 1),
    }


def motion_mode(robot: DdsRobot) -> str:
    """The robot's high-level motion mode in words, asked of its motion switcher (scan reports it, never changes it)."""
    from hw.dds.motion_switcher import MotionSwitcherClient, MotionSwitcherError  # noqa: PLC0415

    if robot.link is None:
        return "unknown (not connected)"
    try:
        name = MotionSwitcherClient(robot.link.session).check_mode()
    except MotionSwitcherError as exc:
        return f"unknown ({exc})"
    if not name:
        return "none active (low-level commands are taken)"
    return f"'{name}' active (the robot's own controller holds the motors; sweep, damp and runs release it)"
