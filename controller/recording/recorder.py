"""The flight recorder's loop side: a copy of each tick handed to the writer thread, and what changed said as a log line.

`record` runs inside the control tick, so it only copies (arrays to lists, a few dicts) and
queues; encoding, compression and the disk are the writer thread's (`sink.McapSink`). Mode
changes, faults, falls and an estimate given up become `foxglove.Log` lines on `/log`; the bus
and estimator counters are sampled once a second of run time and on every such event. No
simulator here: a real robot's run records through this module.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from controller.estimation.estimator import StateEstimator
from controller.recording import foxglove, topics
from controller.recording.sink import QUEUE_ITEMS, McapSink, Message
from controller.recording.tick import Tick
from controller.reference.buffer import ReferenceSample
from controller.reports import percentiles_ms
from hw.robot import RobotInterface
from hw.types import RobotState

COUNTERS_PERIOD_S = 1.0  # run time between two samples of the counters
FORMAT = "g1ctl-recording-1"  # the `format` of the `run` metadata: what this module writes

# foxglove.Log levels
INFO, WARNING, ERROR = 2, 3, 4


@runtime_checkable
class CountedRobot(Protocol):
    """A hardware robot (buses or DDS): its link counters and its lifecycle's."""

    def counters(self) -> Any: ...
    def lifecycle_report(self) -> dict[str, object]: ...


@dataclasses.dataclass(slots=True)
class _Item:
    """One tick as queued: its time, the payloads of `topics.PAYLOAD_TOPICS`, the joints, the poses, the log lines."""

    time: float
    payloads: dict[str, Any]
    joints: tuple[list[float], list[float], list[float] | None]
    frames: list[tuple[str, list[float], list[float]]]  # world -> child frame: its name, position, quaternion (w, x, y, z)
    logs: list[tuple[int, str, str]]  # level, source, text


class FlightRecorder:
    """Records every tick of a session into an MCAP file; `close` finishes it, `report` says what was written."""

    def __init__(
        self, path: Path, robot: RobotInterface, estimator: StateEstimator | None, run: dict[str, Any], queue_items: int = QUEUE_ITEMS,
    ) -> None:  # fmt: skip
        """Start recording to `path` (ConfigError when it cannot be written); `run` describes the run in the file's metadata.

        `robot` is the backend's (its counters, where it is a hardware robot), `estimator` the state estimator where one runs."""
        self.joint_names = tuple(robot.joint_names)
        self._counted = robot if isinstance(robot, CountedRobot) else None
        self._estimator = estimator
        self._mode = ""
        self._fault: str | None = None
        self._estimate_fault: str | None = None
        self._next_counters = -math.inf
        self._pending: list[tuple[int, str, str]] = []  # lines said outside a tick (`note`), sent with the next item
        self.ticks = 0
        self.call_seconds: list[float] = []  # what `record` cost the tick
        metadata = {"format": FORMAT, "joint_names": json.dumps(self.joint_names), "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        metadata |= {key: value if isinstance(value, str) else json.dumps(value) for key, value in run.items()}
        self.sink = McapSink(path, self._encode, metadata, queue_items)  # last: its thread starts here

    # -- the loop's side ------------------------------------------------------------------
    def record(self, tick: Tick) -> None:
        """Copy what the tick read, decided and sent, and queue it; never waits."""
        start = time.perf_counter()
        logs = self._events(tick)
        payloads = _payloads(tick)
        if tick.truth is not None:
            payloads["truth"] = _base(tick.truth)
        estimator = self._estimator
        if estimator is not None:
            payloads["estimate"] = _base(tick.state) | {"contacts": list(estimator.contacts), "position_std": float(estimator.position_std)}
        t = tick.state.time
        if logs or t >= self._next_counters:
            self._next_counters = t + COUNTERS_PERIOD_S
            payloads |= self._counters()
        reading = tick.reading
        joints = (reading.joint_pos.tolist(), reading.joint_vel.tolist(), None if reading.joint_tau is None else reading.joint_tau.tolist())
        self.sink.offer(_Item(t, payloads, joints, _frames(tick), logs))
        self.ticks += 1
        self.call_seconds.append(time.perf_counter() - start)

    def _events(self, tick: Tick) -> list[tuple[int, str, str]]:
        """The /log lines of this tick: a mode change (a warning unless to run), a fault, a fall, an estimate given up."""
        logs, self._pending = self._pending, []
        if tick.mode != self._mode:
            was = f"{self._mode} -> " if self._mode else ""
            text = f"mode {was}{tick.mode}" + (f": {tick.reason}" if tick.reason else "")
            logs.append((INFO if tick.mode == "run" else WARNING, "supervisor", text))
            self._mode = tick.mode
        if tick.fault != self._fault:
            if tick.fault is not None:
                logs.append((ERROR, "fault", tick.fault))
            self._fault = tick.fault
        if tick.fell:
            logs.append((ERROR, "session", "the robot fell"))
        estimator = self._estimator
        if estimator is not None and estimator.fault != self._estimate_fault:
            self._estimate_fault = estimator.fault
            if estimator.fault is not None:
                logs.append((ERROR, "estimator", f"state estimate lost: {estimator.fault}"))
        return logs

    def note(self, source: str, text: str, level: int = ERROR) -> None:
        """A line said outside a tick (a fault at bring-up): written with the next tick, or on its own at `close`."""
        self._pending.append((level, source, text))

    def _counters(self) -> dict[str, Any]:
        counters: dict[str, Any] = {}
        if self._counted is not None:
            counters["bus"] = dataclasses.asdict(self._counted.counters()) | self._counted.lifecycle_report()
        if self._estimator is not None:
            counters["estimator"] = {"updates": len(self._estimator.update_seconds), "fault": self._estimator.fault}
        return counters

    def close(self, time_s: float | None = None) -> None:
        """Finish the file (safe twice); lines still pending (a bring-up fault) are written first, at `time_s`."""
        if self._pending and time_s is not None:
            logs, self._pending = self._pending, []
            self.sink.offer(_Item(time_s, self._counters(), ([], [], None), [], logs))
        self.sink.close()

    def report(self) -> dict[str, Any]:
        """The report's `recorder` block: where, how much, what was dropped, what recording cost the tick."""
        return self.sink.report() | {"ticks": self.ticks, "record_ms": percentiles_ms(self.call_seconds)}

    # -- the writer thread's side ---------------------------------------------------------
    def _encode(self, item: _Item) -> list[Message]:
        ns = max(0, round(item.time * 1e9))
        messages: list[Message] = []
        for key, payload in item.payloads.items():
            topic = topics.PAYLOAD_TOPICS[key]
            data = topic.proto(**payload).SerializeToString() if topic.proto is not None else json.dumps(payload).encode()
            messages.append((topic, ns, data))
        q, dq, tau = item.joints
        if q:
            messages.append((topics.JOINTS, ns, foxglove.joint_states(item.time, self.joint_names, q, dq, tau)))
        if item.frames:
            messages.append((topics.TF, ns, foxglove.frame_transforms(item.time, item.frames)))
        messages += [(topics.LOG, ns, foxglove.log(item.time, level, source, text)) for level, source, text in item.logs]
        return messages


def _payloads(tick: Tick) -> dict[str, Any]:
    """The per-tick topics every run has, as plain values (copies: the writer reads them later)."""
    reading, window, command, sample = tick.reading, tick.window, tick.command, tick.sample
    return {
        "state": {
            "time": float(reading.time), "base_quat": reading.base_quat.tolist(), "base_ang_vel": reading.base_ang_vel.tolist(),
            "imu_accel": None if reading.imu_accel is None else reading.imu_accel.tolist(), "base_pos": reading.base_pos.tolist(),
            "base_lin_vel": reading.base_lin_vel.tolist(), "has_base_position": bool(reading.has_base_position),
        },
        "command": {
            "q": command.q.tolist(), "dq": command.dq.tolist(), "kp": command.kp.tolist(), "kd": command.kd.tolist(),
            "tau_ff": command.tau_ff.tolist(),
        },
        "reference": {
            "time": float(window.time), "velocity": _velocity(*_triple(window.velocity)),
            "path_velocity": None if window.path_velocity is None else _velocity(*_triple(window.path_velocity)),
            "plan": _sample(window.plan), "ahead": _sample(window.ahead),
        },
        "input": {
            "velocity": _velocity(*_triple(sample.velocity)), "start": sample.buttons.start, "stop": sample.buttons.stop,
            "estop": sample.buttons.estop, "alive": sample.alive, "gesture": sample.gesture,
        },
        "supervisor": {"mode": tick.mode, "reason": tick.reason, "fault": tick.fault},
        "tracking": {
            "commanded": _velocity(*_triple(tick.velocity)),
            "measured": None if tick.measured_velocity is None else _velocity(*tick.measured_velocity),
        },
    }  # fmt: skip


def _frames(tick: Tick) -> list[tuple[str, list[float], list[float]]]:
    """World -> pelvis by the truth where there is one, else as the controller saw it; beside a truth, what it saw."""
    frames = []
    if tick.truth is not None:
        frames.append((foxglove.PELVIS, tick.truth.base_pos.tolist(), tick.truth.base_quat.tolist()))
    if tick.state.has_base_position:
        seen = foxglove.PELVIS_ESTIMATE if tick.truth is not None else foxglove.PELVIS
        frames.append((seen, tick.state.base_pos.tolist(), tick.state.base_quat.tolist()))
    return frames


def _velocity(vx: float, vy: float, yaw_rate: float) -> dict[str, float]:
    return {"vx": float(vx), "vy": float(vy), "yaw_rate": float(yaw_rate)}


def _triple(velocity: Any) -> tuple[float, float, float]:
    return velocity.vx, velocity.vy, velocity.yaw_rate


def _base(state: RobotState) -> dict[str, Any]:
    return {"base_pos": state.base_pos.tolist(), "base_lin_vel": state.base_lin_vel.tolist(), "base_quat": state.base_quat.tolist()}


def _sample(sample: ReferenceSample | None) -> dict[str, Any] | None:
    if sample is None:
        return None
    return {
        "time": float(sample.time), "qpos": sample.qpos.tolist(), "root_velocity": sample.root_velocity.tolist(),
        "yaw_rate": float(sample.yaw_rate), "joint_velocity": sample.joint_velocity.tolist(), "held": bool(sample.held),
    }  # fmt: skip
