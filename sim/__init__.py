"""MuJoCo world of the Unitree G1: scene, simulated robot, rendering.

MuJoCo picks its OpenGL backend when it is first imported, so a headless machine's
default (EGL) is set here, before any module of this package imports `mujoco`.
"""

import os

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"
