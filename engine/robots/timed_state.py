"""What a robot is doing, timed on the simulation clock: the metrics read the seconds spent in
each state, the energy model how long the current spell of charging has lasted."""

from __future__ import annotations


class TimedState:
    """The current state, since when, and the seconds of every closed spell."""

    __slots__ = ("closed", "since", "value")

    def __init__(self, value: str, since: float) -> None:
        self.value = value
        self.since = since
        self.closed: dict[str, float] = {}

    def enter(self, value: str, now: float) -> bool:
        """Close the current spell at `now` and open one of `value`; False (nothing done) if
        the robot is in that state already."""
        if value == self.value:
            return False
        self.closed[self.value] = self.closed.get(self.value, 0.0) + (now - self.since)
        self.value, self.since = value, now
        return True

    def times(self, now: float) -> dict[str, float]:
        """Seconds in each state, the current spell up to `now` (they add up to now − the
        first spell's start)."""
        out = dict(self.closed)
        out[self.value] = out.get(self.value, 0.0) + (now - self.since)
        return out
