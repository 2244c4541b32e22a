"""Pictures of planned motion: filmstrips and side-by-side videos of G1 poses (`g1ctl viz plan`)."""

from __future__ import annotations

from pathlib import Path

import imageio.v2 as imageio
import mujoco
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure  # its own canvas: no pyplot, no global backend

from sim.render import render_poses


def columns_of(length: int, count: int = 6) -> list[int]:
    """`count` plan frames spread evenly from the first to the last."""
    return sorted({round(float(v)) for v in np.linspace(0, length - 1, count)})


def filmstrip(model: mujoco.MjModel, context: np.ndarray, rows: dict[str, np.ndarray], lookat: np.ndarray, path: Path) -> None:
    """Rows of poses (one per seed or source) at a few plan frames, after the last context frame, as a PNG."""
    length = len(next(iter(rows.values())))
    columns = columns_of(length)
    fig = Figure(figsize=(2.2 * (len(columns) + 1), 1.8 * len(rows)))
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(rows), len(columns) + 1, squeeze=False)
    context_image = render_poses(model, context[-1:], lookat)[0]
    for r, (label, frames) in enumerate(rows.items()):
        images = [context_image, *render_poses(model, frames[columns], lookat)]
        titles = ["context", *(f"+{(c + 1) / 30:.2f} s" for c in columns)]
        for c, (image, title) in enumerate(zip(images, titles, strict=True)):
            ax = axes[r, c]
            ax.imshow(image)
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(title, fontsize=8)
        axes[r, 0].set_ylabel(label, fontsize=8)
    fig.suptitle("planned motion: last context frame, then plan frames (the last column is the target frame)", fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def video(model: mujoco.MjModel, context: np.ndarray, rows: dict[str, np.ndarray], lookat: np.ndarray, path: Path) -> None:
    """The context then each row's plan, side by side, as an .mp4 or .gif at 30 fps."""
    strips = [render_poses(model, np.concatenate((context, frames)), lookat, width=256, height=256) for frames in rows.values()]
    path.parent.mkdir(parents=True, exist_ok=True)
    frames = [np.concatenate(row, axis=1) for row in zip(*strips, strict=True)]
    if path.suffix.lower() == ".mp4":
        writer = imageio.get_writer(str(path), fps=30, codec="libx264", quality=7, macro_block_size=8)
    else:
        writer = imageio.get_writer(str(path), mode="I", duration=1000.0 / 30, loop=0)
    with writer:
        for frame in frames:
            writer.append_data(frame)
