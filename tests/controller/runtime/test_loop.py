"""The fixed-rate loop and the bus cycle pacer under a fake clock: pacing on deadlines, overruns and missed cycles counted."""

from __future__ import annotations

import pytest

from controller.runtime.loop import CyclePacer, FakeClock, RateLoop, RealtimeSimulationClock, SimulationClock


def test_ticks_on_deadlines_for_the_duration() -> None:
    clock = FakeClock()
    loop = RateLoop(clock, 50.0)
    starts = [clock.now() for _ in loop.run(1.0)]
    assert len(starts) == 50
    assert starts[:3] == pytest.approx([0.0, 0.02, 0.04])
    assert loop.overruns == 0


def test_slow_ticks_are_counted_and_schedule_reanchors() -> None:
    clock = FakeClock()
    loop = RateLoop(clock, 10.0)
    starts = []
    for tick in loop.run(1.0):
        starts.append(clock.now())
        clock.advance(0.25 if tick == 2 else 0.01)  # tick 2 takes 2.5 periods
    assert loop.overruns == 1
    assert starts[3] == pytest.approx(0.45)  # started at once after the late tick, not bursting
    assert starts[4] == pytest.approx(0.55)


def test_work_within_period_is_no_overrun() -> None:
    clock = FakeClock()
    loop = RateLoop(clock, 100.0)
    for _ in loop.run(0.5):
        clock.advance(0.009)
    assert loop.overruns == 0 and loop.ticks == 50


def test_simulation_clock_advances_physics_to_deadlines() -> None:
    sim_time = [0.0]
    calls = []

    def advance_to(t: float) -> None:
        calls.append(t)
        sim_time[0] = t

    loop = RateLoop(SimulationClock(lambda: sim_time[0], advance_to), 50.0)
    assert sum(1 for _ in loop.run(0.1)) == 5
    assert calls == pytest.approx([0.02, 0.04, 0.06, 0.08, 0.1])


def test_realtime_clock_counts_physics_falling_behind_the_wall() -> None:
    wall = FakeClock(100.0)
    sim_time = [0.0]

    def slow_physics(t: float) -> None:
        wall.advance(0.03 if t > 0.05 else 0.005)  # physics slower than real time after 50 ms
        sim_time[0] = t

    clock = RealtimeSimulationClock(lambda: sim_time[0], slow_physics, wall=wall)
    loop = RateLoop(clock, 50.0)
    for _ in loop.run(0.2):
        pass
    assert loop.overruns >= 5
    assert wall.now() > 100.2


def test_rate_must_be_positive() -> None:
    with pytest.raises(ValueError):
        RateLoop(FakeClock(), 0.0)


def test_bus_cycles_run_on_their_deadlines_until_the_tick() -> None:
    clock = FakeClock()
    pacer = CyclePacer(clock, 250.0)
    starts: list[float] = []

    def cycle() -> None:
        starts.append(clock.now())
        clock.advance(0.001)

    pacer.run_until(0.02, cycle)
    assert starts == pytest.approx([0.0, 0.004, 0.008, 0.012, 0.016, 0.02])
    assert clock.now() == pytest.approx(0.021) and pacer.missed == 0 and pacer.cycles == 6
    pacer.run_until(0.04, cycle)  # the next tick's share: the grid goes on where it was
    assert starts[6:] == pytest.approx([0.024, 0.028, 0.032, 0.036, 0.04])
    assert pacer.periods == pytest.approx([0.004] * 10)


def test_a_late_cycle_is_counted_as_missed_not_caught_up_with_a_burst() -> None:
    clock = FakeClock()
    pacer = CyclePacer(clock, 250.0)
    starts: list[float] = []

    def cycle() -> None:
        starts.append(clock.now())
        clock.advance(0.001)

    pacer.run_until(0.008, cycle)  # cycles at 0, 4 and 8 ms
    clock.advance(0.0095)  # the control tick's work ran long: it is now 18.5 ms, the 12 and 16 ms cycles are due
    pacer.run_until(0.028, cycle)
    # One cycle at once for the slots passed (12 ms missed, 16 ms taken late), then the grid again: never two in a slot.
    assert starts == pytest.approx([0.0, 0.004, 0.008, 0.0185, 0.02, 0.024, 0.028])
    assert pacer.missed == 1 and pacer.cycles == 7 and pacer.cycles + pacer.missed == 8  # 8 slots from 0 to 28 ms
    assert max(pacer.periods) == pytest.approx(0.0105)


def test_a_cycle_late_by_less_than_a_period_keeps_the_grid() -> None:
    clock = FakeClock()
    pacer = CyclePacer(clock, 500.0)
    starts: list[float] = []

    def cycle() -> None:
        starts.append(clock.now())
        clock.advance(0.0025 if len(starts) == 2 else 0.0005)  # the second cycle overruns its 2 ms by half a period

    pacer.run_until(0.01, cycle)
    assert starts == pytest.approx([0.0, 0.002, 0.0045, 0.006, 0.008, 0.01]) and pacer.missed == 0
