"""An MIT bus driver on a real python-can virtual bus, answered by hand from the motor side."""

from __future__ import annotations

import time
import uuid

import can
import numpy as np

from hw.drivers import MitBusDriver, MitMotor
from hw.feedback import FeedbackStore, MitReplyBank
from hw.protocols import mit
from tests.conftest import HANG_S

AK80_9 = mit.MitRanges(p_max=12.5, v_max=50.0, t_max=18.0, kp_max=500.0, kd_max=5.0)


def _rig() -> tuple[MitBusDriver, can.BusABC, MitReplyBank, FeedbackStore]:
    channel = f"driver-test-{uuid.uuid4().hex[:8]}"
    store = FeedbackStore(2)
    bank = MitReplyBank([0, 1], [AK80_9, AK80_9], ["cubemars", "cubemars"])
    motors = [MitMotor(1, AK80_9, "cubemars"), MitMotor(2, AK80_9, "cubemars")]
    driver = MitBusDriver("can0", can.Bus(interface="virtual", channel=channel), motors, [0, 1], store, bank, 0)
    return driver, can.Bus(interface="virtual", channel=channel), bank, store


def _answer(motor_side: can.BusABC, position: float) -> None:
    """Read the commands on the bus and reply to each with `position`."""
    while (cmd := motor_side.recv(timeout=HANG_S)) is not None:  # until motor 2, the last, is answered
        data = mit.encode_reply(AK80_9, "cubemars", cmd.arbitration_id, position, 0.0, 0.0)
        motor_side.send(can.Message(arbitration_id=cmd.arbitration_id, data=data, is_extended_id=False))
        if cmd.arbitration_id == 2:
            return


def test_a_late_reply_never_stands_in_for_the_next_cycles_reply() -> None:
    driver, motor_side, bank, store = _rig()
    batch = np.zeros((2, 8), np.uint8).tobytes()
    try:
        driver.send_frames(batch)
        driver.collect(time.monotonic() + 0.002)  # nobody answers in time
        assert driver.counters.dropped == 2
        _answer(motor_side, position=1.0)  # the replies come late
        driver.send_frames(batch)
        _answer(motor_side, position=2.0)  # this cycle's replies
        driver.collect(time.monotonic() + HANG_S)  # returns once both replies are filed: the deadline only bounds a hang
        bank.publish(store, now=10.0)
        assert store.position.tolist() == [mit.decode_reply(AK80_9, "cubemars", _reply(2.0)).position] * 2
        assert driver.counters.late_replies == 2 and driver.counters.dropped == 2
        assert store.stamp.tolist() == [10.0, 10.0]
    finally:
        driver.close()
        motor_side.shutdown()


def test_late_replies_alone_give_values_but_no_fresh_stamp() -> None:
    driver, motor_side, bank, store = _rig()
    batch = np.zeros((2, 8), np.uint8).tobytes()
    try:
        driver.send_frames(batch)
        driver.collect(time.monotonic() + 0.002)
        _answer(motor_side, position=1.0)  # late
        driver.send_frames(batch)
        driver.collect(time.monotonic() + 0.002)  # and nothing on time again
        bank.publish(store, now=10.0)
        assert store.position.tolist() == [mit.decode_reply(AK80_9, "cubemars", _reply(1.0)).position] * 2
        assert np.isnan(store.stamp).all() and store.missed.tolist() == [2, 2]
    finally:
        driver.close()
        motor_side.shutdown()


def _reply(position: float) -> bytes:
    return mit.encode_reply(AK80_9, "cubemars", 1, position, 0.0, 0.0)
