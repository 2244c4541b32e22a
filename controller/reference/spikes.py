"""Velocity spikes: ticks where the reference handed to the tracker moves much faster than the command.

The command is the one the planner was asked for, or, while the reference slows down after a
command dropped, the root path it was asked for (the command through the root spring): a new
command reaches the reference one splice later (0.13 s) and through the spring (0.3 s
half-life), so a stop from 0.7 m/s reads above 0.5 m/s for about 0.3 s without any spike.

Measured on the reference itself, by finite differences of consecutive ticks' root (planar
position and heading), so a jump from a splice or a re-anchoring counts as much as a fast
plan: a tracker that followed it would be asked for that speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from controller.commands.velocity import VelocityCommand
from hw import g1, quat
from hw.errors import ConfigError
from hw.types import FloatArray


@dataclass(frozen=True)
class SpikeConfig:
    speed_margin_mps: float = 0.5  # planar speed above the command's by more than this: a spike
    yaw_rate_margin_radps: float = 1.0  # ... or yaw rate (magnitude) above the command's by more than this

    def __post_init__(self) -> None:
        if not self.speed_margin_mps > 0 or not self.yaw_rate_margin_radps > 0:
            raise ConfigError(
                f"spike margins must be positive, got speed {self.speed_margin_mps} m/s and yaw rate {self.yaw_rate_margin_radps} rad/s"
            )


class VelocitySpikes:
    """Counts the ticks (`ticks`) and the spikes among them (`spikes`) of one reference, tick by tick (`record`)."""

    def __init__(self, cfg: SpikeConfig = SpikeConfig()) -> None:
        self.cfg = cfg
        self.ticks = 0
        self.spikes = 0
        self._last: tuple[float, float, float, float] | None = None  # time, x, y, heading of the previous tick

    def restart(self) -> None:
        """The reference starts afresh (a run's start, a recovery): no difference is taken across it."""
        self._last = None

    def record(self, t: float, qpos: FloatArray, command: VelocityCommand, path: VelocityCommand | None = None) -> bool:
        """The reference's root `qpos` [36] at run time `t` under `command`; True when the step from the last tick spikes.

        `path`: the velocity of the root path the plan was asked for at `t` (the command through the root
        spring), when one covers it. A reference still slowing down along it after the command dropped
        (a splice away, then a spring's half-life) is judged against it, not against the new command it
        cannot meet at once.
        """
        now = (t, float(qpos[0]), float(qpos[1]), float(quat.heading(qpos[g1.QPOS_ROOT_QUAT])))
        last, self._last = self._last, now
        if last is None or now[0] <= last[0]:
            return False
        dt = now[0] - last[0]
        speed = math.hypot(now[1] - last[1], now[2] - last[2]) / dt
        yaw_rate = abs(float(quat.wrap_angle(now[3] - last[3]))) / dt
        allowed = (command,) if path is None else (command, path)
        spike = (
            speed > max(math.hypot(c.vx, c.vy) for c in allowed) + self.cfg.speed_margin_mps
            or yaw_rate > max(abs(c.yaw_rate) for c in allowed) + self.cfg.yaw_rate_margin_radps
        )
        self.ticks += 1
        self.spikes += spike
        return spike

    @property
    def share(self) -> float:
        return self.spikes / self.ticks if self.ticks else 0.0
