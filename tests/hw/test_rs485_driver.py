"""The RS-485 driver on a real pyserial port (a pseudo-terminal), answered by hand from the motor side."""

from __future__ import annotations

import os
import time
import tty

import numpy as np
import pytest
import serial

from hw.drivers import Rs485BusDriver
from hw.feedback import FeedbackStore
from hw.protocols import unitree_rs485 as rs485
from tests.conftest import HANG_S, wait_for


def _reply(position: float) -> bytes:
    return rs485.encode_reply(3, rs485.MODE_FOC, 0.0, 0.0, position, 30)


@pytest.fixture
def port_pair():  # type: ignore[no-untyped-def]
    master, slave = os.openpty()
    tty.setraw(slave)
    port = serial.serial_for_url(os.ttyname(slave), timeout=0)
    yield port, master
    port.close()
    os.close(master)
    os.close(slave)


def test_a_late_reply_never_stands_in_for_the_next_command_of_the_same_motor(port_pair) -> None:  # type: ignore[no-untyped-def]
    port, motor_side = port_pair
    store = FeedbackStore(1)
    driver = Rs485BusDriver("rs485", port, [3], [0], store)
    zeros = np.zeros(1)
    os.write(motor_side, _reply(1.0))  # the answer to an earlier command, come too late
    assert wait_for(lambda: port.in_waiting >= rs485.REPLY_SIZE)  # through the pseudo-terminal
    driver.send_arrays(zeros, zeros, zeros, zeros, zeros, enabled=True)
    assert driver.write_next(time.monotonic() + HANG_S)  # the reply below comes long before: the deadline only bounds a hang
    os.read(motor_side, rs485.COMMAND_SIZE)
    os.write(motor_side, _reply(2.0))  # this command's answer
    driver.read_pending()
    fb = store.feedback(0)
    assert fb.position == pytest.approx(rs485.decode_reply(_reply(2.0)).position)
    assert driver.counters.late_replies == 1 and driver.counters.dropped == 0


def test_late_replies_alone_give_values_but_no_stamp(port_pair) -> None:  # type: ignore[no-untyped-def]
    port, motor_side = port_pair
    store = FeedbackStore(1)
    driver = Rs485BusDriver("rs485", port, [3], [0], store)
    zeros = np.zeros(1)
    os.write(motor_side, _reply(1.0))
    assert wait_for(lambda: port.in_waiting >= rs485.REPLY_SIZE)
    driver.send_arrays(zeros, zeros, zeros, zeros, zeros, enabled=True)
    driver.collect(time.monotonic() + 0.005)  # the motor stays silent this cycle: whatever the wait, no reply comes
    fb = store.feedback(0)
    assert fb.position == pytest.approx(rs485.decode_reply(_reply(1.0)).position)
    assert fb.stamp is None and fb.missed == 1
