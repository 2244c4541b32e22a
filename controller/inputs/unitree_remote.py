"""The G1's own wireless remote as a command input: `LowState_.wireless_remote` -> command and buttons.

The same mapping as the gamepad (`gamepad.py`): left stick forward/sideways, right stick yaw
rate, start, A stop, B e-stop; X wave, Y raise both arms, L1 point (with the planner). The
sticks read up and right positive, so sideways and yaw are negated (+vy is left, +yaw is
counter-clockwise). The decoding of the 40 bytes is `hw.protocols.unitree_hg`.
`UnitreeRemoteSource` reads them from `rt/lowstate` with its own DDS reader (the `g1` extra);
`remote_bytes` is the inverse mapping, what the simulated robot's remote sends.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from controller.commands.velocity import CommandLimits, VelocityCommand
from controller.inputs.base import Buttons, CommandSample, CommandSource
from controller.inputs.gamepad import apply_deadzone
from hw.dds import cdr, require_cyclonedds
from hw.dds.session import DdsConfig, DdsSession
from hw.errors import ConfigError
from hw.protocols import unitree_hg as hg
from hw.protocols.crc import FrameError
from hw.protocols.unitree_hg import WirelessRemote, decode_wireless_remote, encode_wireless_remote


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


def _stick(value: float, bounds: tuple[float, float], deadzone: float) -> float:
    """The stick deflection that `map_remote` reads as `value` (the inverse of its deadzone and scale)."""
    bound = bounds[1] if value >= 0 else -bounds[0]
    x = min(max(value / bound, -1.0), 1.0) if bound > 0 else 0.0
    return 0.0 if x == 0.0 else math.copysign(abs(x) * (1.0 - deadzone) + deadzone, x)


def remote_bytes(sample: CommandSample, limits: CommandLimits, cfg: RemoteConfig = RemoteConfig()) -> bytes:
    """The 40 `wireless_remote` bytes that `map_remote` reads back as `sample` (not alive: sticks centred)."""
    held = {b for b, on in ((cfg.button_start, sample.buttons.start), (cfg.button_stop, sample.buttons.stop),
                            (cfg.button_estop, sample.buttons.estop)) if on}  # fmt: skip
    if sample.gesture:
        button = next((b for b, name in cfg.gesture_buttons if name == sample.gesture), None)
        if button is None:
            names = ", ".join(name for _, name in cfg.gesture_buttons)
            raise ConfigError(f"gesture '{sample.gesture}' has no button on the G1's remote (it has buttons for {names})")
        held.add(button)
    v = sample.velocity if sample.alive else VelocityCommand()
    remote = WirelessRemote(
        lx=-_stick(v.vy, limits.vy, cfg.deadzone),  # map_remote negates sideways and yaw
        ly=_stick(v.vx, limits.vx, cfg.deadzone),
        rx=-_stick(v.yaw_rate, limits.yaw_rate, cfg.deadzone),
        buttons=frozenset(held),
    )
    return encode_wireless_remote(remote)


def remote_feed(source: CommandSource, limits: CommandLimits, cfg: RemoteConfig = RemoteConfig()) -> Callable[[float], bytes]:
    """A function of time giving `source`'s command as remote bytes: the simulated robot's `remote`."""
    return lambda t: remote_bytes(source.poll(t), limits, cfg)


class UnitreeRemoteSource(CommandSource):
    """The remote in the robot's `LowState_`s, read with its own reader on `dds`; each poll takes what arrived.

    A state with a bad CRC or that is no `LowState_` is counted and dropped. With no good state for
    `cfg.stale_timeout` (robot gone, cable out, or none yet) the remote is not alive, like an
    unplugged gamepad: the run loop damps."""

    _needs_close = True

    def __init__(
        self, dds: DdsConfig, limits: CommandLimits, cfg: RemoteConfig = RemoteConfig(), clock: Callable[[], float] = time.monotonic
    ) -> None:
        require_cyclonedds()
        from hw.dds import messages  # noqa: PLC0415 - cyclonedds: the g1 extra

        self._cfg = cfg
        self._limits = limits
        self._clock = clock
        self._session = DdsSession(dds)
        self._reader: Any = self._session.reader(dds.lowstate_topic, messages.LowState_)
        self.remote = WirelessRemote()  # from the newest good state
        self.state_time = -math.inf  # clock time it arrived
        self.states = self.crc_errors = self.bad_frames = 0

    def _take(self) -> None:
        for data in DdsSession.take_cdr(self._reader):
            try:
                record = cdr.low_state_from_cdr(data)
            except FrameError:
                self.bad_frames += 1
                continue
            if not hg.crc_ok(record):
                self.crc_errors += 1
                continue
            self.states += 1
            self.remote, self.state_time = decode_wireless_remote(record["wireless_remote"]), self._clock()

    def poll(self, now: float) -> CommandSample:
        self._take()
        return map_remote(self.remote, self._cfg, self._limits, age_s=self._clock() - self.state_time)

    def close(self) -> None:
        if self._closed:
            return
        self._session.close()
        super().close()
