"""Fixed-rate loop paced on deadlines by an injectable clock, counting overruns.

The same loop runs as fast as possible on simulated time (tests, benchmarks) and in
wall-clock real time for people: only the clock changes. A tick whose work runs past
the next deadline is an overrun; it is counted and the schedule re-anchors to now
instead of bursting to catch up.
"""

from __future__ import annotations

import abc
import time
from collections.abc import Callable, Iterator


class Clock(abc.ABC):
    """Seconds on one monotonic time line.

    `late_ticks` counts deadlines the clock itself missed inside `sleep_until` (a
    real-time simulation whose physics fell behind the wall clock).
    """

    late_ticks = 0

    @abc.abstractmethod
    def now(self) -> float: ...

    @abc.abstractmethod
    def sleep_until(self, deadline: float) -> None:
        """Return at or after `deadline` (immediately when it has passed)."""


class WallClock(Clock):
    def now(self) -> float:
        return time.monotonic()

    def sleep_until(self, deadline: float) -> None:
        delay = deadline - time.monotonic()
        if delay > 0:
            time.sleep(delay)


class RunClock(WallClock):
    """The wall clock counting from its creation: a run's time line when the robot runs on its own (a real robot)."""

    def __init__(self) -> None:
        self._start = time.monotonic()

    def now(self) -> float:
        return time.monotonic() - self._start

    def sleep_until(self, deadline: float) -> None:
        delay = deadline - self.now()
        if delay > 0:
            time.sleep(delay)


class FakeClock(Clock):
    """A clock tests move by hand; `sleep_until` jumps to the deadline."""

    def __init__(self, start: float = 0.0) -> None:
        self.t = start

    def now(self) -> float:
        return self.t

    def advance(self, dt: float) -> None:
        self.t += dt

    def sleep_until(self, deadline: float) -> None:
        self.t = max(self.t, deadline)


class SimulationClock(Clock):
    """Simulated time: sleeping advances the physics to the deadline, as fast as it can."""

    def __init__(self, time_fn: Callable[[], float], advance_to: Callable[[float], None]) -> None:
        self._time_fn = time_fn
        self._advance_to = advance_to

    def now(self) -> float:
        return self._time_fn()

    def sleep_until(self, deadline: float) -> None:
        self._advance_to(deadline)


class RealtimeSimulationClock(SimulationClock):
    """Simulated time held to the wall clock: physics to the deadline, then wait for the wall."""

    def __init__(self, time_fn: Callable[[], float], advance_to: Callable[[float], None], wall: Clock | None = None) -> None:
        super().__init__(time_fn, advance_to)
        self._wall = wall or WallClock()
        self._offset: float | None = None

    def sleep_until(self, deadline: float) -> None:
        self._advance_to(deadline)
        if self._offset is None:
            self._offset = self._wall.now() - deadline
            return
        wall_deadline = deadline + self._offset
        if self._wall.now() > wall_deadline:
            self.late_ticks += 1
        self._wall.sleep_until(wall_deadline)


class RateLoop:
    """Yields tick indices at `rate_hz` on `clock`; `overruns` counts ticks whose work ran past the next deadline."""

    def __init__(self, clock: Clock, rate_hz: float) -> None:
        if rate_hz <= 0:
            raise ValueError(f"rate must be positive, got {rate_hz}")
        self.clock = clock
        self.period = 1.0 / rate_hz
        self._late_work = 0
        self.ticks = 0

    @property
    def overruns(self) -> int:
        return self._late_work + self.clock.late_ticks

    def run(self, duration: float | None = None) -> Iterator[int]:
        """Tick until `duration` seconds have passed on the clock (forever when None)."""
        deadline = self.clock.now()
        end = None if duration is None else deadline + duration - 1e-9
        while end is None or deadline < end:
            yield self.ticks
            self.ticks += 1
            deadline += self.period
            now = self.clock.now()
            if now > deadline:
                self._late_work += 1
                deadline = now
            else:
                self.clock.sleep_until(deadline)


class CyclePacer:
    """Bus cycles at `rate_hz` on `clock`'s deadlines, for a robot whose buses run on the wall clock.

    Each cycle starts at its deadline on a fixed grid. A cycle that could only start a whole period or more after its
    deadline (the work before it ran long: a control tick, a stall of the machine) is not made up for with a burst: the
    slots it passed are counted in `missed` and it runs at once, in the grid's latest slot. `periods` holds the times
    from one cycle's start to the next (what the motors see), `cycles` how many ran.
    """

    def __init__(self, clock: Clock, rate_hz: float) -> None:
        if rate_hz <= 0:
            raise ValueError(f"rate must be positive, got {rate_hz}")
        self.clock = clock
        self.period = 1.0 / rate_hz
        self.missed = 0
        self.cycles = 0
        self.periods: list[float] = []
        self._next: float | None = None  # the next cycle's deadline
        self._last_start: float | None = None

    def run_next(self, cycle: Callable[[], None]) -> None:
        """Wait for the next deadline and run `cycle` then (at once, counting the slots passed, when it is long gone)."""
        if self._next is None:
            self._next = self.clock.now()
        self.clock.sleep_until(self._next)
        start = self.clock.now()
        behind = int((start - self._next) / self.period)  # whole periods past the deadline
        if behind > 0:
            self.missed += behind
            self._next += behind * self.period
        if self._last_start is not None:
            self.periods.append(start - self._last_start)
        self._last_start = start
        cycle()
        self.cycles += 1
        self._next += self.period

    def run_until(self, t: float, cycle: Callable[[], None]) -> None:
        """Every cycle due by `t`, each at its deadline; then wait until `t`."""
        if self._next is None:
            self._next = self.clock.now()
        while self._next <= t + 1e-9:
            self.run_next(cycle)
        self.clock.sleep_until(t)
