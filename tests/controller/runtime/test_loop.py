"""The fixed-rate loop under a fake clock: pacing on deadlines, overruns counted."""

from __future__ import annotations

import pytest

from controller.runtime.loop import FakeClock, RateLoop, RealtimeSimulationClock, SimulationClock


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
