"""Joint commands are read-only: the hardware layer re-sends an unchanged command by identity."""

from __future__ import annotations

import numpy as np
import pytest

from hw.types import JointCommand, read_only


def test_writable_arrays_are_copied_and_frozen() -> None:
    q = np.zeros(3)
    command = JointCommand(q=q, dq=q, kp=q, kd=q, tau_ff=q)
    q[0] = 1.0  # the producer's buffer changes after the write...
    assert command.q[0] == 0.0  # ...the command does not
    with pytest.raises(ValueError, match="read-only"):
        command.q[0] = 2.0


def test_read_only_arrays_are_shared_without_a_copy() -> None:
    zeros = read_only(np.zeros(3))
    command = JointCommand(q=zeros, dq=zeros, kp=zeros, kd=zeros, tau_ff=zeros)
    assert command.q is zeros and command.tau_ff is zeros
    assert read_only(zeros) is zeros
