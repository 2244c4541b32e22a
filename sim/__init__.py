"""MuJoCo world of the Unitree G1: scene, simulated robot, rendering.

Importing this package changes no global state. MuJoCo chooses its OpenGL backend from
`MUJOCO_GL` when `mujoco` is first imported (checked with mujoco 4.0: set later, it is
ignored), so a command that renders calls `use_headless_gl()` before it imports `mujoco` or
any module of this package that does.
"""

from __future__ import annotations

import logging
import os
import sys

log = logging.getLogger(__name__)

HEADLESS_GL = "egl"


def use_headless_gl() -> str:
    """Choose EGL offscreen rendering when there is no display and `MUJOCO_GL` is not set;
    returns the backend in force ("" for MuJoCo's default, which needs a display).

    The choice goes into the environment, so child processes inherit it; a backend the user
    set is kept. Call it before `mujoco` is imported: afterwards the choice no longer applies
    to this process, and a warning says so."""
    if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
        if "mujoco" in sys.modules:
            log.warning("MuJoCo was imported before the headless OpenGL backend was chosen: offscreen rendering may fail here")
        os.environ["MUJOCO_GL"] = HEADLESS_GL
    return os.environ.get("MUJOCO_GL", "")
