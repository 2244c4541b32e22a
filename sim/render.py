"""Offscreen rendering of the simulated G1 to MP4/GIF video and PNG pictures.

Headless machines render with EGL (`MUJOCO_GL=egl`): MuJoCo reads that variable when it is
first imported, so a command that renders calls `sim.use_headless_gl()` before it imports
MuJoCo (`g1ctl sim` and `g1ctl viz plan` do; so must any other command that renders).
Shadows, reflections and the skybox are off: on a CPU-only machine they cost about
four times the frame time for little a person watching a gait needs.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from types import TracebackType
from typing import Any

import imageio.v2 as imageio
import mujoco
import numpy as np

from hw.errors import G1Error


class RenderError(G1Error, RuntimeError):
    """Offscreen rendering is not available on this machine."""


def _make_renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    try:
        renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:  # EGL/OSMesa failures come as various exception types
        raise RenderError(
            f"cannot render offscreen ({exc}); set MUJOCO_GL=egl or osmesa before MuJoCo is imported"
            " (a command that renders calls sim.use_headless_gl() first), or drop --video/--picture"
        ) from exc
    flags = renderer.scene.flags
    flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
    flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
    flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = 0
    return renderer


def render_picture(model: mujoco.MjModel, data: mujoco.MjData, path: Path, width: int = 640, height: int = 480) -> None:
    """Write a PNG of the current state seen from the tracking camera."""
    renderer = _make_renderer(model, width, height)
    try:
        renderer.update_scene(data, camera=model.camera("track").id)
        save_png(renderer.render(), path)
    finally:
        renderer.close()


class Ghost:
    """A translucent copy of the G1 at a reference pose (the plan being tracked), added to a scene.

    Drawn beside the real robot in videos and in the viewer, so a person sees at once
    where the tracker is asked to go and how far the robot is from it.
    """

    def __init__(self, model: mujoco.MjModel, rgba: tuple[float, float, float, float] = (0.25, 0.85, 0.35, 0.35)) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self._option = mujoco.MjvOption()
        self._perturb = mujoco.MjvPerturb()
        self._rgba = np.array(rgba, dtype=np.float32)

    def add_to(self, scene: mujoco.MjvScene, qpos: np.ndarray) -> None:
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        first = scene.ngeom
        mujoco.mjv_addGeoms(self.model, self.data, self._option, self._perturb, mujoco.mjtCatBit.mjCAT_DYNAMIC, scene)
        for i in range(first, scene.ngeom):
            scene.geoms[i].rgba[:] = self._rgba


class VideoRecorder:
    """Captures frames from a tracking camera at `fps` of simulated time and writes them on close;
    a `ghost_qpos` given to `maybe_capture` is drawn as a translucent robot beside the real one."""

    def __init__(self, model: mujoco.MjModel, path: Path, fps: int = 25, width: int = 640, height: int = 480) -> None:
        if path.suffix.lower() not in (".mp4", ".gif"):
            raise RenderError(f"video path must end in .mp4 or .gif, got {path.name}")
        self._renderer = _make_renderer(model, width, height)
        self.path = path
        self.fps = fps
        self._next_t = 0.0
        self._camera = model.camera("track").id
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.suffix.lower() == ".mp4":
            self._writer = imageio.get_writer(str(path), fps=fps, codec="libx264", quality=7, macro_block_size=8)
        else:
            self._writer = imageio.get_writer(str(path), mode="I", duration=1000.0 / fps, loop=0)
        self._open = True
        self.frames = 0
        self._ghost = Ghost(model)

    def maybe_capture(self, data: mujoco.MjData, ghost_qpos: np.ndarray | None = None, caption: str | None = None) -> None:
        """Capture a frame when simulated time has reached the next frame time, with `caption` written on it."""
        if data.time + 1e-9 < self._next_t:
            return
        self._renderer.update_scene(data, camera=self._camera)
        if ghost_qpos is not None:
            self._ghost.add_to(self._renderer.scene, ghost_qpos)
        frame = self._renderer.render()
        if caption:
            frame = with_caption(frame, caption)
        self._writer.append_data(frame)
        self.frames += 1
        self._next_t += 1.0 / self.fps

    def close(self) -> None:
        if self._open:
            self._open = False
            self._writer.close()
            self._renderer.close()

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()


def with_caption(frame: np.ndarray, text: str) -> np.ndarray:
    """`frame` (H x W x 3 uint8) with `text` on a dark band along its bottom edge."""
    from PIL import Image, ImageDraw  # noqa: PLC0415 - Pillow comes with matplotlib

    image = Image.fromarray(frame)
    draw = ImageDraw.Draw(image)
    band = 28
    draw.rectangle((0, image.height - band, image.width, image.height), fill=(0, 0, 0))
    draw.text((8, image.height - band + 7), text[:90], fill=(255, 255, 255))
    return np.asarray(image)


def save_png(frame: np.ndarray, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    imageio.imwrite(str(path), frame)


def render_poses(model: mujoco.MjModel, poses: np.ndarray, lookat: np.ndarray, width: int = 320, height: int = 240) -> list[np.ndarray]:
    """Images of each `qpos` in `poses` [T, nq] seen from a fixed side camera aimed at `lookat` (kinematics only)."""
    renderer = _make_renderer(model, width, height)
    data = mujoco.MjData(model)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = lookat
    camera.distance, camera.azimuth, camera.elevation = 2.4, 120.0, -10.0
    model.vis.headlight.ambient[:] = 0.45  # the side view faces away from the scene light
    model.vis.headlight.diffuse[:] = 0.6
    images = []
    try:
        for qpos in poses:
            data.qpos[:] = qpos
            mujoco.mj_kinematics(model, data)
            renderer.update_scene(data, camera=camera)
            images.append(renderer.render().copy())
    finally:
        renderer.close()
    return images


def open_viewer(model: mujoco.MjModel, data: mujoco.MjData) -> Any:
    """MuJoCo's interactive passive viewer (a context manager with `sync()`); it needs a display."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        # Checked here: without a display GLFW's initialisation ends the whole process.
        raise RenderError("the MuJoCo viewer needs a display and DISPLAY is not set: drop --viewer, or use --video")
    import mujoco.viewer  # noqa: PLC0415 - GLFW: only where a viewer is asked for

    try:
        return mujoco.viewer.launch_passive(model, data)
    except Exception as exc:  # GLFW raises plain RuntimeError without a display
        raise RenderError(f"cannot open the MuJoCo viewer ({exc}); it needs a display: drop --viewer or use --video") from exc
