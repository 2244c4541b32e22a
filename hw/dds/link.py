"""The host's end of the G1's low-level DDS link: `LowCmd_` out on `rt/lowcmd`, the newest `LowState_` in.

What the lifecycle robot builds on (configure, soft start, 500 Hz cycle, damping):

- `connect(timeout_s)`: wait for the robot's first `LowState_` with a good CRC and learn its
  `mode_machine` (every command must carry it), or fail naming the domain and interface.
- `send(record)`: stamp `mode_machine` and the CRC on a `LowCmd_` record and publish it.
  Messages go through `hw.dds.cdr` (numpy, microseconds), not Cyclone's Python serializer.
- `poll(now)`: take what arrived, keep the newest state whose CRC matches (a bad one is
  counted, never used), and say how old the newest good state is (`age`): a robot whose
  state stops coming is stale, and the caller damps.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hw.dds import cdr, messages
from hw.dds.session import DdsConfig, DdsSession
from hw.errors import HardwareFault
from hw.protocols import unitree_hg as hg
from hw.protocols.crc import FrameError


class RobotNotFoundError(HardwareFault):
    """No `LowState_` came from the robot."""


@dataclass
class LinkCounters:
    commands_sent: int = 0
    states_received: int = 0  # with a good CRC
    crc_errors: int = 0  # states whose CRC did not match: dropped
    bad_frames: int = 0  # samples that are no LowState_ (size, encapsulation): dropped
    mode_machine_changes: int = 0  # the robot reported another mode_machine than at connect
    bad_in_a_row: int = 0  # states with a bad CRC since the last good one


class DdsLink:
    """One host's link to one robot over a `DdsSession`."""

    def __init__(self, cfg: DdsConfig, clock: Callable[[], float] = time.monotonic) -> None:
        self.cfg = cfg
        self.clock = clock
        self.session = DdsSession(cfg)
        self._writer = self.session.writer(cfg.lowcmd_topic, messages.LowCmd_)
        self._reader = self.session.reader(cfg.lowstate_topic, messages.LowState_)
        self._arrived = self.session.wait_set(self._reader)
        self._write, self._take = DdsSession.cdr_writer(self._writer), DdsSession.cdr_taker(self._reader)
        self.counters = LinkCounters()
        self.mode_machine: int | None = None  # stamped on every command: the robot's at connect
        self.reported_mode_machine: int | None = None  # what the newest good state says
        self.data: bytes | None = None  # the newest LowState_ with a good CRC, as CDR (`cdr.state_health` reads it in place)
        self.state_time = -np.inf  # clock time it arrived
        self._arrays: cdr.JointArrays | None = None  # views and record of it, built when asked for
        self._record: np.ndarray | None = None

    @property
    def arrays(self) -> cdr.JointArrays | None:
        """The newest good state's joints and IMU as views (the same object until the next good state)."""
        if self._arrays is None and self.data is not None:
            self._arrays = cdr.joint_arrays(self.data)
        return self._arrays

    @property
    def state(self) -> np.ndarray | None:
        """The newest good `LowState_` as a record (built on first use)."""
        if self._record is None and self.data is not None:
            self._record = cdr.low_state_from_cdr(self.data)
        return self._record

    def connect(self, timeout_s: float = 2.0) -> np.ndarray:
        """The robot's first good `LowState_`; its `mode_machine` is kept for every command."""
        deadline = self.clock() + timeout_s
        while self.clock() < deadline:
            if self.poll() is not None and self.state is not None:
                self.mode_machine = int(self.state["mode_machine"])
                return self.state
            time.sleep(0.002)
        bad = f" ({self.counters.crc_errors} with a bad CRC)" if self.counters.crc_errors else ""
        raise RobotNotFoundError(
            f"no LowState_ from the robot on DDS domain {self.cfg.domain}, interface '{self.cfg.interface}' in {timeout_s:g} s{bad}: "
            "check that it is powered, the cable is in, and the domain and interface are the robot's"
        )

    def poll(self) -> float | None:
        """Take what arrived; the age (s) of the newest good state, None before the first."""
        now = self.clock()
        for data in self._take():
            try:
                crc_ok = cdr.low_state_crc_ok(data)
            except FrameError:
                self.counters.bad_frames += 1
                continue
            if not crc_ok:
                self.counters.crc_errors += 1
                self.counters.bad_in_a_row += 1
                continue
            self.counters.states_received += 1
            self.counters.bad_in_a_row = 0
            self.reported_mode_machine = data[cdr.MODE_MACHINE_AT]
            if self.mode_machine is not None and self.reported_mode_machine != self.mode_machine:
                self.counters.mode_machine_changes += 1
            self.data, self._arrays, self._record, self.state_time = data, None, None, now
        return None if self.data is None else now - self.state_time

    def wait(self, timeout_s: float) -> None:
        """Block until a `LowState_` is waiting (at most `timeout_s`): the benchmark's round trip waits on the answer."""
        self._arrived(timeout_s)

    def send(self, record: np.ndarray) -> None:
        """Publish a `LowCmd_` record with the robot's `mode_machine` and the CRC set."""
        self.send_cdr(self.encode(record))

    def encode(self, record: np.ndarray) -> bytes:
        """A `LowCmd_` record as the CDR `send_cdr` publishes: the robot's `mode_machine` and the CRC stamped.

        Apart from `send` so that a command that does not change is encoded once and re-sent.
        """
        if self.mode_machine is None:
            raise HardwareFault("send before connect: the robot's mode_machine is not known yet")
        out = hg.canonical(record)
        out["mode_machine"] = self.mode_machine
        return cdr.low_cmd_to_cdr(hg.with_crc(out))

    def send_cdr(self, data: bytes) -> None:
        self._write(data)
        self.counters.commands_sent += 1

    def close(self) -> None:
        self.session.close()
