"""Physics side of motion dataset recording: foot contacts from MuJoCo, and state sampled at a frame rate.

The orchestration (policy, command programs, gestures) lives in `controller.eval.dataset_recorder`;
this module only reads the simulated G1.
"""

from __future__ import annotations

import mujoco
import numpy as np
from numpy.typing import NDArray

from hw import g1 as constants
from hw.errors import ConfigError
from hw.types import FloatArray
from sim.robot import SimRobot

FLOOR_GEOM = "floor"


class FootContacts:
    """Which feet touch the floor now: any MuJoCo contact between a foot body's geoms and the floor."""

    def __init__(self, model: mujoco.MjModel, foot_bodies: tuple[str, str] = constants.ANKLE_BODIES, floor: str = FLOOR_GEOM) -> None:
        try:
            self._floor = model.geom(floor).id
            feet = [model.body(name).id for name in foot_bodies]
        except KeyError as exc:
            raise ConfigError(f"the G1 scene has no floor geom '{floor}' or foot bodies {foot_bodies}: {exc}") from exc
        # Side of each geom: 0 left foot, 1 right foot, 2 anything else.
        self._side = np.full(model.ngeom + 1, 2, dtype=np.int64)
        for side, body in enumerate(feet):
            self._side[np.flatnonzero(model.geom_bodyid == body)] = side
        if not (self._side == 0).any() or not (self._side == 1).any():
            raise ConfigError(f"the foot bodies {foot_bodies} of the G1 scene have no geoms")

    def read(self, data: mujoco.MjData) -> NDArray[np.bool_]:
        """[left, right] in contact with the floor (contacts have zero margin here: touching or penetrating)."""
        out = np.zeros(2, dtype=bool)
        n = data.ncon
        if n == 0:
            return out
        geoms = data.contact.geom[:n]
        on_floor = (geoms == self._floor).any(axis=1)
        other = np.where(geoms[:, 0] == self._floor, geoms[:, 1], geoms[:, 0])[on_floor]
        sides = self._side[other]
        out[0] = bool((sides == 0).any())
        out[1] = bool((sides == 1).any())
        return out


def restart(robot: SimRobot, yaw: float = 0.0) -> None:
    """Stand the robot at the origin facing `yaw`, damped, with the clock at zero.

    Zeroing the clock makes an episode depend on its seed alone: physics and sampling
    times then add up the same floats whatever ran before.
    """
    robot.reset(yaw=yaw)
    robot.data.time = 0.0


class FrameSampler:
    """Advances a `SimRobot` and samples qpos and foot contacts at every frame time on the way.

    Frame k of a take is at `start + k / fps`; it is sampled at the physics step nearest that
    time (within half a physics step, 1 ms at 500 Hz), so rates that do not divide the
    physics rate (30 fps against 500 Hz) keep their timing without drift.
    """

    def __init__(self, robot: SimRobot, fps: float = 30.0) -> None:
        if fps <= 0:
            raise ConfigError(f"frame rate must be positive, got {fps}")
        self.robot = robot
        self.fps = fps
        self.feet = FootContacts(robot.model)
        self._half_step = 0.5 * robot.timestep
        self.start()

    def start(self) -> None:
        """Begin a new take at the robot's current time (frame 0 is sampled on the next advance)."""
        self.t0 = self.robot.time
        self._qpos: list[FloatArray] = []
        self._contacts: list[NDArray[np.bool_]] = []

    @property
    def frames(self) -> int:
        return len(self._qpos)

    def next_frame_time(self) -> float:
        return self.t0 + len(self._qpos) / self.fps

    def advance_to(self, t: float) -> None:
        """Step physics to time `t` under the robot's current command, sampling every frame due by then."""
        robot = self.robot
        while (tf := self.next_frame_time()) - self._half_step <= t + 1e-9:
            robot.step_until(tf - self._half_step)
            self._qpos.append(robot.data.qpos.copy())
            self._contacts.append(self.feet.read(robot.data))
        robot.step_until(t)

    def take(self, frames: int | None = None) -> tuple[FloatArray, NDArray[np.bool_]]:
        """The first `frames` (default all) samples of this take: qpos [T, 36] and contacts [T, 2]."""
        n = self.frames if frames is None else max(0, min(frames, self.frames))
        qpos = np.array(self._qpos[:n]).reshape(n, -1)
        contacts = np.array(self._contacts[:n], dtype=bool).reshape(n, 2)
        return qpos, contacts
