"""The MIT reply bank agrees with the scalar codec, row by row, for every reply variant."""

from __future__ import annotations

import math

import pytest

from hw.feedback import FeedbackStore, MitReplyBank
from hw.protocols import mit

AK80_9 = mit.MitRanges(p_max=12.5, v_max=50.0, t_max=18.0, kp_max=500.0, kd_max=5.0)
DM4310 = mit.MitRanges(p_max=12.5, v_max=30.0, t_max=10.0, kp_max=500.0, kd_max=5.0)
# (robot joint index, ranges, variant, motor id): rows in bank order, joints deliberately not in order
MOTORS = [(4, AK80_9, "basic", 1), (0, AK80_9, "cubemars", 2), (2, DM4310, "damiao", 3), (1, DM4310, "cubemars", 4)]


def _bank() -> tuple[MitReplyBank, FeedbackStore]:
    bank = MitReplyBank([j for j, _, _, _ in MOTORS], [r for _, r, _, _ in MOTORS], [v for _, _, v, _ in MOTORS])
    return bank, FeedbackStore(5)


def _reply(row: int, position: float, code: int = 0, temperature: float = 40.0) -> bytes:
    _, r, variant, motor_id = MOTORS[row]
    return mit.encode_reply(r, variant, motor_id, position, -1.5, 2.0, temperature=temperature, error_code=code)  # type: ignore[arg-type]


def test_rows_decode_like_the_scalar_codec_and_unanswered_rows_stay_empty() -> None:
    bank, store = _bank()
    for row in (0, 1, 2):  # row 3 never answers
        bank.pending.append((row, _reply(row, 0.3 * row - 0.2, code=1 if row == 2 else 0)))
    bank.publish(store, now=7.0)
    for row in (0, 1, 2):
        j, r, variant, _ = MOTORS[row]
        expected = mit.decode_reply(r, variant, _reply(row, 0.3 * row - 0.2, code=1 if row == 2 else 0))  # type: ignore[arg-type]
        fb = store.feedback(j)
        assert (fb.position, fb.velocity, fb.torque) == (expected.position, expected.velocity, expected.torque)
        assert fb.stamp == 7.0 and fb.error == expected.error and fb.faulted == expected.faulted
        assert fb.temperature == (None if variant == "basic" else expected.temperature)
    silent = store.feedback(MOTORS[3][0])
    assert silent.stamp is None and silent.position == 0.0 and silent.temperature is None


def test_only_new_replies_are_stamped_and_codes_change_names() -> None:
    bank, store = _bank()
    for row in range(4):
        bank.pending.append((row, _reply(row, 0.1)))
    bank.publish(store, now=1.0)
    bank.publish(store, now=2.0)  # nothing new: nothing changes
    assert [store.feedback(j).stamp for j, _, _, _ in MOTORS] == [1.0] * 4
    bank.pending.append((1, _reply(1, -0.4, code=2, temperature=-5)))
    bank.publish(store, now=3.0)
    assert [store.feedback(j).stamp for j, _, _, _ in MOTORS] == [1.0, 3.0, 1.0, 1.0]
    fb = store.feedback(MOTORS[1][0])
    assert fb.error == "over-current" and fb.faulted and fb.temperature == -5
    assert math.isclose(fb.position, -0.4, abs_tol=25 / 65535)


@pytest.mark.parametrize("state,faulted", [(0x1, False), (0x0, False), (0xD, True), (0x7, True)])
def test_damiao_states_are_named(state: int, faulted: bool) -> None:
    bank, store = _bank()
    bank.pending.append((2, _reply(2, 0.0, code=state)))
    bank.publish(store, now=1.0)
    fb = store.feedback(MOTORS[2][0])
    assert fb.faulted is faulted
    assert fb.error == mit.DAMIAO_STATES.get(state, f"unknown state {state:#x}")


def test_a_row_that_replied_twice_does_not_stamp_a_silent_one() -> None:
    bank, store = _bank()
    for row in (0, 0, 1, 2):  # a late reply of row 0, then its new one; row 3 silent
        bank.pending.append((row, _reply(row, 0.1)))
    bank.publish(store, now=5.0)
    assert [store.feedback(j).stamp for j, _, _, _ in MOTORS] == [5.0, 5.0, 5.0, None]
