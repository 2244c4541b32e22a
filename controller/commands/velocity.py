"""The velocity command every input gives, every reference carries and every locomotion policy follows."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class VelocityCommand:
    """Planar base velocity in the robot's heading frame: vx forward, vy left (m/s), yaw rate (rad/s)."""

    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0

    def is_zero(self, tol: float = 1e-3) -> bool:
        return abs(self.vx) < tol and abs(self.vy) < tol and abs(self.yaw_rate) < tol


ZERO = VelocityCommand()


@dataclass(frozen=True)
class CommandLimits:
    """Largest magnitudes a command may reach (the policy's trained ranges)."""

    vx: tuple[float, float] = (-1.0, 1.0)
    vy: tuple[float, float] = (-1.0, 1.0)
    yaw_rate: tuple[float, float] = (-1.0, 1.0)

    def clamp(self, cmd: VelocityCommand) -> VelocityCommand:
        return VelocityCommand(
            vx=min(max(cmd.vx, self.vx[0]), self.vx[1]),
            vy=min(max(cmd.vy, self.vy[0]), self.vy[1]),
            yaw_rate=min(max(cmd.yaw_rate, self.yaw_rate[0]), self.yaw_rate[1]),
        )
