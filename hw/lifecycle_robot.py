"""The lifecycle and command path every hardware robot shares (buses: `hw.hardware_robot`; DDS: `hw.dds.robot`).

    UNCONFIGURED --configure--> INACTIVE --activate--> ACTIVATING --ramp done--> ACTIVE
    ACTIVE/ACTIVATING --deactivate--> INACTIVE (damping)
    any --fault--> ERROR (damping every cycle, latched) --rearm--> INACTIVE

What is the same whatever carries the commands lives here: the soft-start ramp, the newest
command through the safety layer (limits and the per-cycle step), a settled command reused
while unchanged, the hold command, latching a fault or damping on purpose, re-arming. A
robot says how to damp now (`_damp_now`), how to bring its measured state up to date
(`_refresh`) and what is wrong with it (`_check_feedback`).
"""

from __future__ import annotations

import abc
import logging
from collections.abc import Callable
from typing import Protocol

import numpy as np

from hw.errors import HardwareFault, LifecycleError
from hw.robot import Lifecycle, RobotInterface
from hw.safety import JointLimits, command_is_finite, limit_command
from hw.types import JointCommand

log = logging.getLogger(__name__)


class CommandSafety(Protocol):
    """The safety thresholds the command path reads (both robots' safety configs have them)."""

    @property
    def soft_start_time(self) -> float: ...
    @property
    def max_position_step(self) -> float: ...
    @property
    def damping_kd(self) -> float: ...


class LifecycleRobot(RobotInterface):
    def __init__(
        self,
        joint_names: tuple[str, ...],
        default_pose: np.ndarray,
        stamp_clock: Callable[[], float],
        limits: JointLimits,
        gains: tuple[np.ndarray, np.ndarray],
        safety: CommandSafety,
    ) -> None:
        """`gains`: the joints' bring-up kp and kd (soft start, hold)."""
        super().__init__()
        self._names = joint_names
        self.stamp_clock = stamp_clock
        self.default_pose = default_pose
        self.limits = limits
        self._safety = safety
        self.state = Lifecycle.UNCONFIGURED
        self.faults: list[str] = []
        self.fault_count = 0
        self.clamped_values = 0
        self.cycles = 0
        n = len(joint_names)
        self._kp, self._kd = gains
        self._damp_kd = np.full(n, safety.damping_kd)
        self._zeros = np.zeros(n)
        self._q, self._dq, self._tau = np.zeros(n), np.zeros(n), np.zeros(n)  # measured, joint side: the robot fills them
        self._command: JointCommand | None = None
        self._sent_q: np.ndarray | None = None
        self._ramp: tuple[float, np.ndarray] | None = None
        self._ramp_target = default_pose
        self._settled: tuple[JointCommand | None, JointCommand | None] = (None, None)  # (written, limited) reused while unchanged
        self._encoded: tuple[JointCommand | None, bytes] = (None, b"")  # (limited command, its encoding)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._names

    def lifecycle_report(self) -> dict[str, object]:
        """What the safety layer did, for a run's report: values clamped, faults and why, the state at the end."""
        return {"clamped_values": self.clamped_values, "faults": self.fault_count, "fault_reasons": self.faults, "state": self.state.value}

    # -- what a robot provides -------------------------------------------------------
    @abc.abstractmethod
    def _damp_now(self) -> None:
        """Send damping on every joint at once."""

    @abc.abstractmethod
    def _check_feedback(self) -> list[str]:
        """Reasons the robot's state is unsafe right now (empty when all is well)."""

    def _refresh(self) -> None:
        """Bring the measured state (`_q`, `_dq`, `_tau`) up to date before a check."""

    # -- lifecycle -------------------------------------------------------------------
    def _start_ramp(self, target_pose: np.ndarray | None) -> None:
        """The soft start after `activate`'s own preparation: check, then ramp from the measured pose."""
        if self.state is not Lifecycle.INACTIVE:
            raise LifecycleError(f"activate needs the robot inactive, it is {self.state.value}")
        faults = self._check_feedback()
        if faults:
            self._enter_error(faults)
            raise HardwareFault(f"cannot activate: {faults[0]}")
        self._forget_settled()
        self._ramp = (self.stamp_clock(), self._q.copy())
        self._ramp_target = self.default_pose if target_pose is None else np.asarray(target_pose, float).copy()
        self._sent_q = self._q.copy()
        self.state = Lifecycle.ACTIVATING

    def rearm(self) -> None:
        """Leave ERROR explicitly once the feedback is healthy again; the robot is then INACTIVE."""
        if self.state is not Lifecycle.ERROR:
            raise LifecycleError(f"rearm needs the robot in error, it is {self.state.value}")
        self._damp_now()
        self._refresh()
        faults = self._check_feedback()
        if faults:
            raise HardwareFault(f"cannot re-arm: {faults[0]}")
        self.faults = []
        self.state = Lifecycle.INACTIVE

    # -- control ---------------------------------------------------------------------
    def write(self, command: JointCommand) -> None:
        """Newest command for the next cycles. The robot keeps it: do not change its arrays afterwards."""
        if not command_is_finite(command):
            self._enter_error(["non-finite joint command from the controller"])
            return
        self._command = command

    def damp(self) -> None:
        if self.state not in (Lifecycle.UNCONFIGURED, Lifecycle.CLOSED):
            self._damp_now()

    def enter_damping(self, reason: str) -> None:
        """Latch damping on purpose (not a fault): every cycle damps until `rearm()`."""
        if self.state in (Lifecycle.UNCONFIGURED, Lifecycle.CLOSED):
            raise LifecycleError(f"damping needs a configured robot, it is {self.state.value}")
        log.info("damping: %s", reason)
        self.state, self.faults, self._command = Lifecycle.ERROR, [reason], None
        self._damp_now()

    def _next_command(self) -> JointCommand:
        """The command for this cycle: the soft-start ramp, the hold, or the newest command within the limits."""
        safety = self._safety
        if self.state is Lifecycle.ACTIVATING and self._ramp is not None:
            start_t, start_q = self._ramp
            alpha = min((self.stamp_clock() - start_t) / max(safety.soft_start_time, 1e-9), 1.0)
            q = start_q + alpha * (self._ramp_target - start_q)
            cmd = JointCommand(q=q, dq=self._zeros, kp=self._kp, kd=self._kd, tau_ff=self._zeros)
            if alpha >= 1.0:
                self.state, self._ramp, self._command = Lifecycle.ACTIVE, None, cmd
        elif self._command is None:
            return self._hold_command()
        else:
            cmd = self._command
            written, settled = self._settled
            if cmd is written and settled is not None:
                # The controller writes at 50 Hz, this runs at 500 Hz: a command that already
                # passed the limits unchanged passes them again, encoding and all.
                return settled
        limited, changed = limit_command(cmd, self.limits, self._sent_q, safety.max_position_step)
        self.clamped_values += changed
        self._sent_q = limited.q
        self._settled = (cmd, limited) if changed == 0 and self.state is Lifecycle.ACTIVE else (None, None)
        return limited

    def _hold_command(self) -> JointCommand:
        self._refresh()
        q = self._sent_q if self._sent_q is not None else self._q
        return JointCommand(q=q, dq=self._zeros, kp=self._kp, kd=self._damp_kd, tau_ff=self._zeros)

    def _forget_settled(self) -> None:
        """After any state change a command must pass the limits (and the step limit) afresh."""
        self._settled, self._encoded = (None, None), (None, b"")

    def _enter_error(self, faults: list[str]) -> None:
        if self.state is not Lifecycle.ERROR:
            log.error("hardware fault, damping all joints: %s", "; ".join(faults))
            self.fault_count += 1
            self.faults = faults
        self.state = Lifecycle.ERROR
        self._command = None
        self._forget_settled()
        self._damp_now()
