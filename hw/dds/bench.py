"""The bench interface (`hw.bench.BenchRobot`) on a G1 over DDS (`DdsRobot`).

The robot's main board reports every motor in each `LowState_`, so a scan is the newest state
read as a table, and the IMU is the one in that state. The G1 has no zero: its `LowCmd_` has no
encoder-zero command, and `zero` is refused in one line. A G1 boots under its own controller
(a high-level motion mode) that keeps it standing: the robot is opened only listening, and its
motion service is released (when the config asks) at the first call that commands it (a move, a
sweep, damping), so a scan or an IMU reading leaves a standing robot standing.
"""

from __future__ import annotations

from hw.bench import BenchRobot, JointStatus, Pump, ZeroResult
from hw.dds.robot import DdsRobot
from hw.errors import ConfigError


def zero_refusal(config_name: str) -> str:
    """The one line that refuses a zero on a G1 over DDS (the bench call and `g1ctl hw zero`)."""
    return (
        f"setting a joint zero has no meaning on a G1 over DDS ('{config_name}'): its joint zeros are set at the factory "
        "and its LowCmd_ has no encoder-zero command"
    )


class DdsBenchRobot(BenchRobot):
    """A G1 over its low-level DDS topics, real or simulated. `robot` was configured only listening; `release_motion_service`:
    the config asks to release the robot's high-level motion service before commanding it."""

    transport = "dds"
    SCAN_COLUMNS = ("joint", "id", "temperature", "voltage", "error", "mode", "q")

    def __init__(self, robot: DdsRobot, pump: Pump, config_name: str, release_motion_service: bool) -> None:
        super().__init__(robot, robot.cfg.joints, pump, config_name, robot.cfg.safety.max_temperature)
        self.g1 = robot
        self._release = release_motion_service

    def status(self) -> list[JointStatus]:
        age_ms = round(1e3 * self.g1.state_age(), 1)  # one LowState_ carries every joint: one age
        rows = []
        for slot, j in enumerate(self.g1.joints()):
            healthy = j.error_bits == 0 and j.temperature <= self.max_temperature
            error = f"{j.error_bits:#010x}"
            rows.append(JointStatus(j.name, "dds", slot, True, j.q, j.dq, j.tau, j.temperature, error, healthy, age_ms, j.voltage, j.mode))
        return rows

    def notes(self) -> list[str]:
        record = self.g1.low_state
        mode_machine = "-" if record is None else int(record["mode_machine"])
        return [f"mode_machine {mode_machine}; high-level motion mode: {motion_mode(self.g1)}"]

    def _take_motors(self) -> None:
        if self._release:
            self.g1.release_motion_service()
            self._release = False  # once: a mode the robot re-enters later is for the safety layer to catch

    def _refuse_zero(self) -> None:
        raise ConfigError(zero_refusal(self.config_name))

    def _zero(self, joint: str) -> ZeroResult:
        raise ConfigError(zero_refusal(self.config_name))

    def _imu_stamp(self) -> float | None:
        link = self.g1.link
        return None if link is None or link.data is None else float(link.state_time)

    def _imu_counts(self) -> tuple[int, int, int | None]:
        c = self.g1.counters()
        return c.states_received, c.crc_errors, None

    def _imu_silent(self, seconds: float) -> str:
        dds = self.g1.cfg.dds
        return f"no LowState_ from the robot in {seconds} s (DDS domain {dds.domain}, interface '{dds.interface}'): is it still on?"


def motion_mode(robot: DdsRobot) -> str:
    """The robot's high-level motion mode in words, asked of its motion switcher (a scan reports it, never changes it)."""
    from hw.dds.motion_switcher import MotionSwitcherClient, MotionSwitcherError  # noqa: PLC0415

    if robot.link is None:
        return "unknown (not connected)"
    try:
        name = MotionSwitcherClient(robot.link.session).check_mode()
    except MotionSwitcherError as exc:
        return f"unknown ({exc})"
    if not name:
        return "none active (low-level commands are taken)"
    return f"'{name}' active (the robot's own controller holds the motors; a move, a sweep, damping and runs release it)"
