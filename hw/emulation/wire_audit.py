"""What reached the motors, as their firmware decoded it from the frames: the judge of a fault drill.

The host's own counters say what it meant to send; a drill is judged on what arrived. Every
emulated motor reports each control step: the command it decoded (joint side, quantized as
the firmware sees it) and the state it is in: `active` (holding a position with stiffness),
`damping` (zero stiffness, some damping: the host's safe state), `limp` (no torque: its own
watchdog, a latched error, motor mode off) or `seized` (the stuck-motor drill). The audit
counts commands outside the joint map's limits and finds when every motor was last brought
to a safe state and stayed there.

An independent judge: it reads the joint map itself and shares no code with the host's safety
layer (`hw.safety`), so a mistake there cannot hide itself here.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from hw.types import LimitedJoint

MotorState = Literal["active", "damping", "limp", "seized"]
SAFE: frozenset[str] = frozenset({"damping", "limp"})
EXAMPLES_KEPT = 5


# The codecs quantize what they carry, so a command at a limit may decode a hair past it: a
# position by under 1e-3 rad, a velocity or torque by under 1 % of its limit (12-bit MIT fields).
TOLERANCE_REL = 0.01
TOLERANCE_ABS = 1e-3


@dataclass(frozen=True)
class WireLimits:
    """The joint map's limits in joint order, widened by one quantization step."""

    q_min: np.ndarray
    q_max: np.ndarray
    dq_max: np.ndarray
    tau_max: np.ndarray

    @staticmethod
    def of(names: tuple[str, ...], joints: Mapping[str, LimitedJoint]) -> WireLimits:
        q = np.array([joints[n].position_limits for n in names], dtype=float)
        dq = np.array([joints[n].velocity_limit for n in names], dtype=float)
        tau = np.array([joints[n].torque_limit for n in names], dtype=float)
        widen = 1 + TOLERANCE_REL
        return WireLimits(q[:, 0] - TOLERANCE_ABS, q[:, 1] + TOLERANCE_ABS, dq * widen + TOLERANCE_ABS, tau * widen + TOLERANCE_ABS)

    def outside(self, index: np.ndarray, q: np.ndarray, dq: np.ndarray, kp: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Per command (joints `index`, joint side): True where it leaves the limits. A position counts only with
        stiffness (kp > 0): a damping command carries none. Not finite is outside."""
        with np.errstate(invalid="ignore"):
            q_bad = (kp > 0) & ~((q >= self.q_min[index]) & (q <= self.q_max[index]))
            return q_bad | ~(np.abs(dq) <= self.dq_max[index]) | ~(np.abs(tau) <= self.tau_max[index]) | ~np.isfinite(kp)

    def outside_one(self, i: int, q: float, dq: float, kp: float, tau: float) -> bool:
        """`outside` for one command in plain floats: a motor reports one per control step, 29 of them at 500 Hz,
        where numpy's per-call cost would be most of the audit's (11 us a command against under 1)."""
        q_min, q_max, dq_max, tau_max = self._scalars[i]
        q_bad = kp > 0 and not q_min <= q <= q_max
        return q_bad or not abs(dq) <= dq_max or not abs(tau) <= tau_max or not math.isfinite(kp)

    @functools.cached_property
    def _scalars(self) -> list[tuple[float, float, float, float]]:
        return [
            (float(a), float(b), float(c), float(d)) for a, b, c, d in zip(self.q_min, self.q_max, self.dq_max, self.tau_max, strict=True)
        ]


@dataclass(frozen=True)
class WireViolation:
    time: float
    joint: str
    q: float
    dq: float
    tau: float


class WireAudit:
    """Fed by the emulated motors (one call per motor and control step, or one per whole-robot frame)."""

    def __init__(self, names: tuple[str, ...], limits: WireLimits) -> None:
        self.names = names
        self.limits = limits
        self._index = {name: i for i, name in enumerate(names)}
        self.commands = 0
        self.last_time: float | None = None
        self.outside = 0
        self.examples: list[WireViolation] = []
        self.state: list[MotorState | None] = [None] * len(names)
        self.safe_from = np.full(len(names), np.nan)  # when each motor last became safe (NaN: it is not)
        self.safe_kind: list[str] = [""] * len(names)  # how each motor is safe now: "damping" or "limp"

    def motor_step(self, joint: str, time: float, state: MotorState, command: tuple[float, float, float, float] | None) -> None:
        """One motor's control step: its state, and the command it decoded now (q, dq, kp, tau; joint side) if any."""
        i = self._index[joint]
        if command is not None:
            self.commands += 1
            if self.limits.outside_one(i, *command):
                self._violation(time, i, command[0], command[1], command[3])
        self._set_state(i, time, state)

    def robot_command(self, time: float, q: np.ndarray, dq: np.ndarray, kp: np.ndarray, tau: np.ndarray) -> None:
        """A whole-robot command (a G1's `LowCmd_`) as decoded, every joint at once; states follow per `motor_step`."""
        self._check(time, np.arange(len(self.names)), q, dq, kp, tau)

    def _check(self, time: float, index: np.ndarray, q: np.ndarray, dq: np.ndarray, kp: np.ndarray, tau: np.ndarray) -> None:
        self.commands += len(index)
        for k in np.flatnonzero(self.limits.outside(index, q, dq, kp, tau)):
            self._violation(time, int(index[k]), float(q[k]), float(dq[k]), float(tau[k]))

    def _violation(self, time: float, i: int, q: float, dq: float, tau: float) -> None:
        self.outside += 1
        if len(self.examples) < EXAMPLES_KEPT:
            self.examples.append(WireViolation(round(time, 4), self.names[i], q, dq, tau))

    def _set_state(self, i: int, time: float, state: MotorState) -> None:
        self.last_time = time if self.last_time is None else max(self.last_time, time)
        was_safe = self.state[i] in SAFE
        self.state[i] = state
        if state in SAFE:
            self.safe_kind[i] = state
            if not was_safe:
                self.safe_from[i] = time
        else:
            self.safe_from[i] = np.nan

    def safe_since(self) -> float | None:
        """The time from which every motor has been safe (None: one is still active, or never reported)."""
        if np.isnan(self.safe_from).any():
            return None
        return float(self.safe_from.max())

    def report(self) -> dict[str, Any]:
        since = self.safe_since()
        return {
            "commands": self.commands,
            "outside_limits": self.outside,
            "outside_examples": [vars(v) for v in self.examples],
            "safe_since": None if since is None else round(since, 4),
            "observed_until": None if self.last_time is None else round(self.last_time, 4),
            "limp_joints": [n for n, kind in zip(self.names, self.safe_kind, strict=True) if since is not None and kind == "limp"],
        }
