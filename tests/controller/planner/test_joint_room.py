"""Joint limits in the planner's output space: corrections squashed into the room the base leaves."""

from __future__ import annotations

import numpy as np
import pytest

from controller.planner.joint_room import within_room

LOWER, UPPER = np.array([-1.0, -0.5]), np.array([1.0, 0.5])


def test_a_small_correction_is_kept_and_a_large_one_never_reaches_the_limit() -> None:
    base = np.zeros((1, 2))
    small = within_room(base, np.array([[0.01, -0.005]]), LOWER, UPPER)
    np.testing.assert_allclose(small, [[0.01, -0.005]], rtol=1e-3)
    large = within_room(base, np.array([[0.9, -0.4]]), LOWER, UPPER)
    assert (large[0] < UPPER).all() and (large[0] > LOWER).all()
    assert large[0, 0] == pytest.approx(np.tanh(0.9)) and large[0, 1] == pytest.approx(-0.5 * np.tanh(0.8))
    assert (within_room(base, np.array([[50.0, -50.0]]), LOWER, UPPER) <= UPPER).all()


def test_no_correction_moves_a_joint_further_past_or_onto_a_limit_it_is_at() -> None:
    base = np.array([[1.0, -0.7]])  # at the upper limit; past the lower one
    out = within_room(base, np.array([[0.3, -0.2]]), LOWER, UPPER)
    np.testing.assert_array_equal(out, base)
    back = within_room(base, np.array([[-0.3, 0.1]]), LOWER, UPPER)  # away from the limit: squashed into the other room
    assert back[0, 0] == pytest.approx(1.0 - 2.0 * np.tanh(0.3 / 2.0)) and back[0, 1] == pytest.approx(-0.7 + 1.2 * np.tanh(0.1 / 1.2))


def test_zero_correction_keeps_the_base_exactly() -> None:
    base = np.array([[0.3, 0.49], [-0.99, 0.0]])
    np.testing.assert_array_equal(within_room(base, np.zeros_like(base), LOWER, UPPER), base)
