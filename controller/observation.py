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

# Terms the runner knows how to compute, with their fixed dimension (None: number of joints).
KNOWN_TERMS: dict[str, int | None] = {
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

    def check(self, num_joints: int, source: str) -> None:
        """Every term must be known and have its expected dimension."""
        for term in self.terms:
            if term.name not in KNOWN_TERMS:
                raise ConfigError(
                    f"{source}: unknown observation term '{term.name}' (known: {', '.join(sorted(KNOWN_TERMS))})"
                )
            expected = KNOWN_TERMS[term.name] or num_joints
            if term.dim != expected:
                raise ConfigError(f"{source}: observation term '{term.name}' has dim {term.dim}, expected {expected}")


class ObservationBuilder:
    """Concatenates scaled terms with per-term history into one float32 row."""

    def __init__(self, layout: ObservationLayout) -> None:
        self.layout = layout
        self._out = np.zeros((1, layout.size), dtype=np.float32)
        h_len = layout.history_length
        self._history = [np.zeros((h_len, t.dim), dtype=np.float32) for t in layout.terms]
        self._slots: list[tuple[str, slice, np.float32]] = []
        col = 0
        for term in layout.terms:
            width = term.dim * h_len
            self._slots.append((term.name, slice(col, col + width), np.float32(term.scale)))
            col += width

    def reset(self) -> None:
        for h in self._history:
            h[:] = 0.0
        self._out[:] = 0.0

    def build(self, values: Mapping[str, FloatArray]) -> np.ndarray:
        """Append this step's term values to the history and return the policy input [1, size].

        Before `history_length` steps have passed the older slots hold zeros, as in
        holosoma's inference runner the policies were exported with.
        """
        row = self._out[0]
        if self.layout.history_length == 1:
            for name, cols, scale in self._slots:
                np.multiply(values[name], scale, out=row[cols], casting="unsafe")
            return self._out
        for (name, cols, scale), hist in zip(self._slots, self._history, strict=True):
            hist[:-1] = hist[1:]
            np.multiply(values[name], scale, out=hist[-1], casting="unsafe")
            row[cols] = hist.reshape(-1)
        return self._out
