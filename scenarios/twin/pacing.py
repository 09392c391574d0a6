"""The served controller's clock kept to the wall clock: the cell's simulated time runs
`speed` times faster than the wall (1: as a controller's), locked anew whenever motion
starts after a pause; a cell that falls behind by more than LAG_S is said, at most once every
ten seconds, and the clock locked again from there."""

from __future__ import annotations

import time
from collections.abc import Callable

#: Behind the wall clock by more than this, the cell is lagging [s].
LAG_S = 0.25
#: A lag is said again only after this long [s].
SAY_AGAIN_S = 10.0


class WallClockPacer:
    """Keeps the cell's time `speed` times the wall clock's from the last lock; `on_lag`
    hears what to say when the cell falls behind."""

    def __init__(self, speed: float, time_s: float, on_lag: Callable[[str], None]) -> None:
        self.speed = speed
        self.lag_events = 0
        self._on_lag = on_lag
        self._anchor = (time.monotonic(), time_s)
        self._lagging_since: float | None = None

    def relock(self, time_s: float) -> None:
        """Lock the cell's time `time_s` [s] to the wall clock from now."""
        self._anchor = (time.monotonic(), time_s)

    def keep_pace(self, time_s: float) -> None:
        """Wait until the wall clock reaches the cell's time `time_s` [s]; if it is past it
        by more than LAG_S, say so and lock again."""
        wall0, sim0 = self._anchor
        due = wall0 + (time_s - sim0) / self.speed
        now = time.monotonic()
        if due > now:
            time.sleep(due - now)
        elif now - due > LAG_S:
            self._lagging(now - due, time_s)

    def _lagging(self, behind_s: float, time_s: float) -> None:
        now = time.monotonic()
        if self._lagging_since is None or now - self._lagging_since > SAY_AGAIN_S:
            self.lag_events += 1
            self._on_lag(
                f"the cell runs {behind_s:.2f} s behind the wall clock at speed {self.speed:g}; "
                "clients see it slower than a controller"
            )
            self._lagging_since = now
        self.relock(time_s)


class StandingTicks:
    """The control periods of a controller whose cell stands (its time does not run), kept to
    the wall clock: each due `period_s` after the one before, so a tick that comes late is
    made up by the next ones and the stream keeps its rate; behind by more than LAG_S, the
    ticks start again from now."""

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self._due = time.monotonic()

    def wait_s(self) -> float:
        """How long until the next tick is due [s] (0: due now)."""
        return max(0.0, self._due - time.monotonic())

    def ticked(self) -> None:
        """A standing tick ran: the next is due one period after this one was."""
        now = time.monotonic()
        self._due += self.period_s
        if now - self._due > LAG_S:
            self._due = now

    def follow_on(self) -> None:
        """A tick ran paced otherwise (the cell moving): the next standing one is due one
        period from now."""
        self._due = time.monotonic() + self.period_s
