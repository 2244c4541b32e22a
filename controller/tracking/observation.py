"""Observation layout (declared in YAML) and its assembly into the policy input vector.

A layout is an ordered list of named terms, each with a dimension and a scale, plus a
history length. Assembly is a pure function of the term values, apart from the
history ring the `ObservationBuilder` keeps: each term keeps its own last
`history_length` values, oldest first, and the terms are concatenated in layout order
(holosoma's convention; holosoma itself sorts term names alphabetically).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from hw.errors import ConfigError
from hw.types import FloatArray


@dataclass(frozen=True)
class PerJoint:
    """A term whose dimension is a multiple of the number of joints (the reference's positions and velocities)."""

    count: int


# Terms the trackers know how to compute, with their fixed dimension (None: number of joints).
# The velocity policy computes the first ten, the whole-body tracker (whole_body.py) the
# BeyondMimic ones below them and its own subset of the others.
KNOWN_TERMS: dict[str, int | PerJoint | None] = {
    "base_lin_vel": 3,
    "base_ang_vel": 3,
    "projected_gravity": 3,
    "command_lin_vel": 2,
    "command_ang_vel": 1,
    "dof_pos": None,
    "dof_vel": None,
    "actions": None,
    "sin_phase": 2,
    "cos_phase": 2,
    # holosoma-inference 0.1.3 'wbt' observation (config_values/observation.py): the reference's joint
    # positions then velocities, and the reference torso's rotation in the robot torso's frame as the
    # first two columns of its matrix, row-major.
    "motion_command": PerJoint(2),
    "motion_ref_ori_b": 6,
}


@dataclass(frozen=True)
class ObsTerm:
    name: str
    dim: int
    scale: float = 1.0


@dataclass(frozen=True)
class ObservationLayout:
    terms: tuple[ObsTerm, ...]
    history_length: int = 1

    def __post_init__(self) -> None:
        if self.history_length < 1:
            raise ValueError(f"history_length must be >= 1, got {self.history_length}")
        names = [t.name for t in self.terms]
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate observation term in {names}")

    @property
    def size(self) -> int:
        return sum(t.dim for t in self.terms) * self.history_length

    def check(self, num_joints: int, source: str, computed: frozenset[str] | None = None) -> None:
        """Every term must be known (and one the caller computes, when it says which) and have its expected dimension."""
        for term in self.terms:
            if term.name not in KNOWN_TERMS:
                raise ConfigError(f"{source}: unknown observation term '{term.name}' (known: {', '.join(sorted(KNOWN_TERMS))})")
            if computed is not None and term.name not in computed:
                known = ", ".join(sorted(computed))
                raise ConfigError(f"{source}: observation term '{term.name}' is not one this tracker computes (it computes: {known})")
            spec = KNOWN_TERMS[term.name]
            expected = spec if isinstance(spec, int) else num_joints * (spec.count if spec is not None else 1)
            if term.dim != expected:
                raise ConfigError(f"{source}: observation term '{term.name}' has dim {term.dim}, expected {expected}")


class ObservationBuilder:
    """Concatenates scaled terms with per-term history into one float32 row.

    Callers either pass a mapping of term values to `build`, or, on the hot path, write
    raw (unscaled) values straight into `raw[slot(name)]` and call `commit()`: one
    vector multiply then scales every term at once.
    """

    def __init__(self, layout: ObservationLayout) -> None:
        self.layout = layout
        width = sum(t.dim for t in layout.terms)
        self.raw = np.zeros(width)
        self._scales = np.concatenate([np.full(t.dim, t.scale) for t in layout.terms]) if layout.terms else np.zeros(0)
        self._slots: dict[str, slice] = {}
        col = 0
        for term in layout.terms:
            self._slots[term.name] = slice(col, col + term.dim)
            col += term.dim
        self._current = np.zeros(width, dtype=np.float32)
        self._history = np.zeros((layout.history_length, width), dtype=np.float32)
        self._out = np.zeros((1, layout.size), dtype=np.float32)
        # Output order: for each term, its history oldest first (holosoma's per-term flattening).
        self._gather = np.concatenate(
            [
                (np.arange(layout.history_length)[:, None] * width + np.arange(s.start, s.stop)[None, :]).reshape(-1)
                for s in self._slots.values()
            ]
        ) if layout.terms else np.zeros(0, dtype=int)  # fmt: skip

    def slot(self, name: str) -> slice:
        return self._slots[name]

    def reset(self) -> None:
        self.raw[:] = 0.0
        self._history[:] = 0.0
        self._out[:] = 0.0

    def build(self, values: Mapping[str, FloatArray]) -> np.ndarray:
        """Set every term from `values` and return the policy input [1, size]."""
        for name, cols in self._slots.items():
            self.raw[cols] = np.asarray(values[name]).reshape(-1)
        return self.commit()

    def commit(self) -> np.ndarray:
        """Scale the raw values, append them to the history and return the policy input [1, size].

        Before `history_length` steps have passed the older slots hold zeros, as in
        holosoma's inference runner the policies were exported with.
        """
        if self.layout.history_length == 1:
            np.multiply(self.raw, self._scales, out=self._out[0], casting="unsafe")
            return self._out
        self._history[:-1] = self._history[1:]
        np.multiply(self.raw, self._scales, out=self._history[-1], casting="unsafe")
        np.take(self._history.reshape(-1), self._gather, out=self._out[0])
        return self._out
