"""`g1ctl log plot`: a recording's commanded against measured velocity, and chosen joints' target against measured position.

The velocities are the ones the run's report judged (`/tracking`: the supervisor's command and
the metrics' measurement, by the simulator's truth where there was one); a joint's panel shows
the position target sent (`/command`, left out while the joint had no stiffness: damping) and the
position read (`/joints`). Faults are marked.
Drawn on a `Figure` with its own Agg canvas: no pyplot, no global backend.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from controller.recording import topics
from controller.recording.info import log_lines
from controller.recording.reader import Recording, read_recording
from hw.errors import ConfigError

VELOCITY_AXES = (("vx", "vx (m/s)"), ("vy", "vy (m/s)"), ("yaw_rate", "yaw rate (rad/s)"))


def plot_recording(path: Path, out: Path, joints: Sequence[str] = ()) -> Recording:
    """Write the PNG `out`; the recording as read (its `warning()` says whether it was cut off)."""
    tracking_topic, command_topic = topics.PAYLOAD_TOPICS["tracking"], topics.PAYLOAD_TOPICS["command"]
    keep = {tracking_topic.name, topics.LOG.name} | ({topics.JOINTS.name, command_topic.name} if joints else set())
    recording = read_recording(path, keep=keep)
    tracking = recording.decoded(tracking_topic)
    if not tracking:
        raise ConfigError(f"{path}: no {tracking_topic.name} messages to plot (is it a g1ctl recording, made with --record?)")
    joint_series = _joint_series(recording, path, joints) if joints else {}
    fig = Figure(figsize=(10, 2.3 * (len(VELOCITY_AXES) + len(joint_series)) + 0.6))
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(VELOCITY_AXES) + len(joint_series), 1, sharex=True, squeeze=False)[:, 0]
    t = np.array([time for time, _ in tracking])
    for ax, (key, label) in zip(axes, VELOCITY_AXES, strict=False):
        commanded = np.array([getattr(message.commanded, key) for _, message in tracking])
        measured = np.array([getattr(message.measured, key) if message.HasField("measured") else np.nan for _, message in tracking])
        ax.plot(t, measured, color="tab:blue", linewidth=0.8, label="measured")
        ax.plot(t, commanded, color="tab:red", linewidth=1.5, drawstyle="steps-post", label="commanded")
        ax.set_ylabel(label)
    for ax, (name, (times, target, measured)) in zip(axes[len(VELOCITY_AXES) :], joint_series.items(), strict=True):
        ax.plot(times, measured, color="tab:blue", linewidth=0.8, label="measured")
        ax.plot(times, target, color="tab:red", linewidth=1.2, label="target sent")
        ax.set_ylabel(f"{name.removesuffix('_joint')} (rad)", fontsize=8)
    faults = [(time, f"{source}: {text}") for time, level, source, text in log_lines(recording) if level in ("ERROR", "FATAL")]
    for ax in axes:
        ax.grid(alpha=0.3)
        for time, _ in faults:
            ax.axvline(time, color="black", linestyle="--", linewidth=1.0)
    axes[0].legend(loc="upper right")
    if len(joint_series):
        axes[len(VELOCITY_AXES)].legend(loc="upper right")
    cut = "" if recording.complete else " (cut off)"
    axes[0].set_title(f"{path.name}{cut}: commanded against measured" + (f"; first fault at {faults[0][0]:.2f} s" if faults else ""))
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    return recording


def _joint_series(recording: Recording, path: Path, wanted: Sequence[str]) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Joint name -> (times, position target sent, position read), at the ticks that have both."""
    states = recording.decoded(topics.JOINTS)
    commands = dict(recording.decoded(topics.PAYLOAD_TOPICS["command"]))
    if not states:
        raise ConfigError(f"{path}: no {topics.JOINTS.name} messages: no joints to plot")
    names = [joint.name for joint in states[0][1].joints]
    short = {name.removesuffix("_joint"): name for name in names}
    unknown = [name for name in wanted if name not in names and name not in short]
    if unknown:
        raise ConfigError(f"--joints {','.join(unknown)}: no such joint in {path}; the joints are {', '.join(short)}")
    columns = {short.get(name, name): names.index(short.get(name, name)) for name in wanted}
    ticks = [(t, message) for t, message in states if t in commands]
    times = np.array([t for t, _ in ticks])
    series = {}
    for name, i in columns.items():
        measured = np.array([message.joints[i].position for _, message in ticks])
        target = np.array([commands[t].q[i] if commands[t].kp[i] > 0 else np.nan for t, _ in ticks])  # no stiffness: no target
        series[name] = (times, target, measured)
    return series
