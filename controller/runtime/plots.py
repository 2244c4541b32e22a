"""PNG plot of commanded against measured velocity.

Drawn on a `Figure` with its own Agg canvas: no pyplot, no global backend, nothing changed
for the rest of the process.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from controller.runtime.tracking_metrics import PlanTrackingMetrics, TrackingMetrics


def plot_tracking(
    metrics: TrackingMetrics, path: Path, title: str, damped: tuple[float, str] | None = None, planned: PlanTrackingMetrics | None = None
) -> None:
    """Commanded and measured vx, vy and yaw rate over time; `damped` (time, reason) marks where and why the run damped."""
    t = np.asarray(metrics.times)
    cmd = np.asarray(metrics.commanded).reshape(-1, 3)
    meas = np.asarray(metrics.measured).reshape(-1, 3)
    fig = Figure(figsize=(10, 7))
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 1, sharex=True)
    labels = ("vx (m/s)", "vy (m/s)", "yaw rate (rad/s)")
    for i, (ax, label) in enumerate(zip(axes, labels, strict=True)):
        ax.plot(t, meas[:, i], color="tab:blue", linewidth=0.8, label="measured")
        ax.plot(t, cmd[:, i], color="tab:red", linewidth=1.5, drawstyle="steps-post", label="commanded")
        if planned is not None and planned.times:
            ax.plot(planned.times, np.asarray(planned.planned)[:, i], color="tab:green", linewidth=1.0, label="planned")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    if damped is not None:
        for ax in axes:
            ax.axvline(damped[0], color="black", linestyle="--", linewidth=1.0, label="damped")
        fig.text(0.01, 0.005, textwrap.fill(f"damped at {damped[0]:.3f} s: {damped[1]}", 150), fontsize=8, va="bottom")
    axes[0].legend(loc="upper right")
    axes[0].set_title(title)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout(rect=(0.0, 0.04 if damped is not None else 0.0, 1.0, 1.0))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
