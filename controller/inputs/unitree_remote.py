"""The G1's own wireless remote as a command input: `LowState_.wireless_remote` -> command and buttons.

The same mapping as the gamepad (`gamepad.py`): left stick forward/sideways, right stick yaw
rate, start, A stop, B e-stop; X wave, Y raise both arms, L1 point (with the planner). The
sticks read up and right positive, so sideways and yaw are negated (+vy is left, +yaw is
counter-clockwise). The decoding of the 40 bytes is `hw.protocols.unitree_hg`; the source that
reads them from `rt/lowstate` comes with the DDS backend.
"""

from __future__ import annotations

from dataclasses import dataclass

from controller.inputs.base import Buttons, CommandLimits, CommandSample, VelocityCommand
from controller.inputs.gamepad import apply_deadzone
from hw.protocols.unitree_hg import WirelessRemote


@dataclass(frozen=True)
class RemoteConfig:
    button_start: str = "start"
    button_stop: str = "A"
    button_estop: str = "B"
    gesture_buttons: tuple[tuple[str, str], ...] = (("X", "wave"), ("Y", "raise_both"), ("L1", "point"))
    deadzone: float = 0.1
    stale_timeout: float = 0.5  # s without a fresh LowState_ before the remote counts as gone


def _scale(x: float, bounds: tuple[float, float]) -> float:
    return x * bounds[1] if x >= 0 else -x * bounds[0]


def map_remote(remote: WirelessRemote, cfg: RemoteConfig, limits: CommandLimits, age_s: float = 0.0) -> CommandSample:
    """Remote state `age_s` seconds old -> command sample; too old gives zero motion and `alive=False`."""
    buttons = Buttons(
        start=cfg.button_start in remote.buttons, stop=cfg.button_stop in remote.buttons, estop=cfg.button_estop in remote.buttons
    )
    if age_s > cfg.stale_timeout:
        return CommandSample(buttons=buttons, alive=False)
    vx = apply_deadzone(remote.ly, cfg.deadzone)
    vy = -apply_deadzone(remote.lx, cfg.deadzone)
    yaw = -apply_deadzone(remote.rx, cfg.deadzone)
    velocity = VelocityCommand(_scale(vx, limits.vx), _scale(vy, limits.vy), _scale(yaw, limits.yaw_rate))
    gesture = next((name for button, name in cfg.gesture_buttons if button in remote.buttons), "")
    return CommandSample(velocity=velocity, buttons=buttons, alive=True, gesture=gesture)
