"""The mission clock of a field mission: one that mission control can pause and re-pace for
every process at once.

Mission time is piecewise: from an anchor (wall time `wall`, mission time `t`) it runs at
`speed` × the wall clock, or stands still while `paused`. The world service owns the clock;
a change re-anchors it at its own now and bumps the state's `version`, and every agent adopts
a state only if it is newer than the one it follows (a command, a reply to any world query,
a status poll: whichever comes first), so a late or repeated copy never turns time back.
`now()` never goes backwards either: an agent that heard of a pause after its own time had
passed the pause's time holds its time until the mission's catches up.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

MAX_SPEED = 1e6
"""Past any pace a field mission can run at: a larger speed in a clock state is malformed."""
PAUSED_WAIT_S = 0.1
"""How long (wall) a paused agent's clock loop, or an operation the world answered "paused",
waits before it looks again (a clock command wakes the loop sooner)."""
FOLLOW_POLL_S = 1.0
"""How often (wall) an agent asks the world's status while paused or just after a clock change:
one that missed the command (ring channels drop under load) catches up within this."""
FOLLOW_FOR_S = 10.0
"""How long (wall) after a change an agent keeps polling at `FOLLOW_POLL_S`."""


@dataclass(frozen=True)
class ClockState:
    """One piece of the mission's timeline, as the world service hands it out (JSON)."""

    version: int
    wall: float  # the anchor's wall time (seconds since the epoch)
    t: float  # the mission time at that wall time
    speed: float
    paused: bool

    def at(self, wall: float) -> float:
        return self.t if self.paused else self.t + (wall - self.wall) * self.speed

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def parse(cls, d: Any) -> ClockState | None:
        """The state a peer sent, or None if it is not one (anything on the wire is hostile:
        a NaN or negative speed, a bool for a number, a missing field are all dropped)."""
        if not isinstance(d, dict):
            return None
        version, wall, t, speed, paused = (d.get(k) for k in cls.__dataclass_fields__)
        nums = (wall, t, speed)
        if type(version) is not int or version < 0 or not isinstance(paused, bool):
            return None
        if not all(isinstance(x, int | float) and not isinstance(x, bool) for x in nums):
            return None
        wall_f, t_f, speed_f = (float(x) for x in nums)  # type: ignore[arg-type]
        if not all(math.isfinite(x) for x in (wall_f, t_f, speed_f)):
            return None
        if t_f < 0 or wall_f < 0 or not 0 < speed_f <= MAX_SPEED:
            return None
        return cls(version, wall_f, t_f, speed_f, paused)


class MissionClock:
    """Mission time on this process: `now()` follows the current `ClockState`, never
    backwards. Thread-safe (the agent's clock loop, Zenoh's threads and its watcher read it)."""

    def __init__(
        self, state: ClockState | None = None, wall: Callable[[], float] = time.time
    ) -> None:
        self._wall = wall
        # none yet (an agent before its spawn answer): time 0, standing, older than any
        self._state = state or ClockState(-1, 0.0, 0.0, 1.0, True)
        self._last = 0.0
        self._lock = threading.Lock()
        self.changed_at = -math.inf  # time.monotonic() of the last change adopted

    @classmethod
    def start(cls, speed: float, paused: bool = False) -> MissionClock:
        """A new mission's clock: time 0 now."""
        return cls(ClockState(0, time.time(), 0.0, speed, paused))

    @property
    def state(self) -> ClockState:
        return self._state

    @property
    def speed(self) -> float:
        return self._state.speed

    @property
    def paused(self) -> bool:
        return self._state.paused

    def now(self) -> float:
        with self._lock:
            self._last = max(self._last, self._state.at(self._wall()))
            return self._last

    def set(self, paused: bool | None = None, speed: float | None = None) -> ClockState:
        """The clock's owner changes it: re-anchored at its own now, one version newer."""
        if speed is not None and not 0 < speed <= MAX_SPEED:
            raise ValueError(f"speed: {speed!r} is not a positive pace")
        with self._lock:
            wall = self._wall()
            old = self._state
            t = self._last = max(self._last, old.at(wall))
            self._state = ClockState(
                old.version + 1,
                wall,
                t,
                old.speed if speed is None else float(speed),
                old.paused if paused is None else paused,
            )
            self.changed_at = time.monotonic()
            return self._state

    def adopt(self, d: Any) -> bool:
        """Follow the state `d` if it is a valid one newer than the current one (else
        nothing changes); True if it was adopted."""
        new = ClockState.parse(d)
        with self._lock:
            if new is None or new.version <= self._state.version:
                return False
            self._last = max(self._last, self._state.at(self._wall()))
            self._state = new
            self.changed_at = time.monotonic()
            return True


def advance_to(env: Any, t: float) -> None:
    """A robot's simpy environment brought to mission time `t`: every event due by then
    processed, its clock at `t` (if later), and `env.peek()` the next event still to come.

    simpy's `run(until=t)` stops by raising from the callback of an event it scheduled at
    `t`, and puts that event back at the head of its queue, spent; it is stepped here, or
    `peek()` reads it as due and an agent's clock loop waits its 1 ms floor every turn (it
    did: ~700 turns a second per agent, whatever the speed)."""
    while env.peek() <= t:
        env.step()
    if t > env.now:
        env.run(until=t)  # nothing due: the clock moves on to the wall's time
        if env.peek() <= t:
            env.step()


def poll_every(clock: MissionClock, otherwise: float) -> float:
    """How often (wall) to ask the world's status: often while paused or just after a change
    (the status answer carries the clock), `otherwise` else."""
    recent = time.monotonic() - clock.changed_at < FOLLOW_FOR_S
    return min(FOLLOW_POLL_S, otherwise) if clock.paused or recent else otherwise


def clock_of(reply: Any) -> Any:
    """The clock state a world service's reply carries (every reply does), or None."""
    return reply.get("clock") if isinstance(reply, dict) else None
