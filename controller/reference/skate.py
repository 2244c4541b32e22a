"""Foot skate of the reference handed to the tracker: how fast its planted soles slide.

A sole counts as planted from one tick to the next when it is lower than 5 cm at both
(`plausibility.CONTACT_HEIGHT_M`, the rule `bench inbetween` uses on plans); the skate is
the mean horizontal speed of planted soles over the run. The soles come from the planner's
own leg chains (numpy forward kinematics), in batches, so a tick only stores its frame.
"""

from __future__ import annotations

import functools
import json

import numpy as np

from controller.planner.foot_lock import LegChains, sole_points
from controller.planner.plausibility import CONTACT_HEIGHT_M
from hw.shipped import model_dir
from hw.types import FloatArray

BATCH_TICKS = 50  # frames kept before their soles are computed (about 0.5 ms on the control thread once a second)


class FootSkate:
    """Accumulates the planted soles' horizontal speed, tick by tick (`record`); `mean_mps` over the run."""

    def __init__(self, legs: LegChains) -> None:
        self.legs = legs
        self._times: list[float] = []
        self._frames: list[FloatArray] = []
        self._distance = 0.0  # metres slid by planted soles
        self._planted_s = 0.0  # sole-seconds planted

    def record(self, t: float, qpos: FloatArray) -> None:
        self._times.append(t)
        self._frames.append(np.array(qpos, dtype=np.float64))
        if len(self._frames) >= BATCH_TICKS:
            self._flush(keep_last=True)

    def restart(self) -> None:
        """The reference starts afresh: no step is taken across the restart."""
        self._flush(keep_last=False)

    @property
    def mean_mps(self) -> float:
        self._flush(keep_last=True)
        return self._distance / self._planted_s if self._planted_s > 0 else 0.0

    def _flush(self, keep_last: bool) -> None:
        if len(self._frames) >= 2:
            soles = sole_points(self.legs, np.stack(self._frames))  # [T, 2, 3]
            dt = np.diff(np.asarray(self._times))[:, None]  # [T-1, 1]
            low = soles[..., 2] < CONTACT_HEIGHT_M
            planted = low[:-1] & low[1:] & (dt > 0)
            slid = np.linalg.norm(np.diff(soles[..., :2], axis=0), axis=-1)  # [T-1, 2]
            self._distance += float(slid[planted].sum())
            self._planted_s += float(np.broadcast_to(dt, planted.shape)[planted].sum())
        keep = self._frames[-1:] if keep_last else []
        self._times, self._frames = self._times[-len(keep) :] if keep else [], keep


@functools.cache
def shipped_leg_chains() -> LegChains:
    """The G1's leg chains as the shipped planner's spec holds them (written at export from the MJCF)."""
    return LegChains.from_spec(json.loads((model_dir("planner") / "planner.json").read_text())["legs"])
