"""The playback pool's rules, as plain functions of the parked cursors' times.

A cursor is a replay engine parked at a simulated time (`app/services/playback.py`). Which one
serves a request, which ones are closed when the pool is full and where a new checkpoint is
worth building depend only on those times and on when each was last used, so they are
decided here, apart from any engine.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise
from typing import Protocol, TypeVar

EPS = 1e-9


class Parked(Protocol):
    """A parked cursor as the rules see it: its mission, its time, when it was last used."""

    @property
    def mission_id(self) -> int: ...
    @property
    def at(self) -> float: ...
    @property
    def used(self) -> int: ...


T = TypeVar("T", bound=Parked)


def pick(slots: Sequence[T], mission_id: int, t: float) -> T | None:
    """The mission's cursor latest at or before `t` (the least replay to reach `t`)."""
    before = [s for s in slots if s.mission_id == mission_id and s.at <= t + EPS]
    return max(before, key=lambda s: s.at, default=None)


def evictions(slots: Sequence[T], per_mission: int, capacity: int) -> list[T]:
    """The cursors to close so that no mission has more than `per_mission` and the pool no
    more than `capacity`.

    Within a mission the most recently used cursor (the viewer's playhead) stays, and of the
    others the one closest after another (or after zero) goes first: the survivors stay
    spread over the timeline. Across missions the least recently used go first.
    """
    out: list[T] = []
    for mid in {s.mission_id for s in slots}:
        mine = sorted((s for s in slots if s.mission_id == mid), key=lambda s: s.at)
        while len(mine) > per_mission:
            newest = max(mine, key=lambda s: s.used)
            gaps = [(s.at - (mine[i - 1].at if i else 0.0), s.used, i) for i, s in enumerate(mine)]
            _, _, i = min(g for g in gaps if mine[g[2]] is not newest)
            out.append(mine.pop(i))
    rest = sorted((s for s in slots if s not in out), key=lambda s: s.used)
    out += rest[: max(0, len(rest) - capacity)]
    return out


def gap_to_fill(times: Sequence[float], end: float, per_mission: int) -> float | None:
    """Where the next checkpoint of a mission goes, or None.

    The middle of the widest stretch between its cursors (and 0 and `end`), while that
    stretch is wider than `end / (per_mission - 1)` and the mission has room for a cursor:
    `per_mission - 1` checkpoints cover the timeline and one slot is left for a viewer's
    playhead, so a scrub that carries a checkpoint away leaves room to rebuild it.
    """
    if len(times) >= per_mission or end <= 0 or per_mission < 2:
        return None
    marks = [0.0, *sorted(times), end]
    # the widest stretch; of equal ones the earliest (the cheapest to replay to)
    width, lo = max(((b - a, a) for a, b in pairwise(marks)), key=lambda g: (g[0], -g[1]))
    return lo + width / 2 if width > end / (per_mission - 1) + EPS else None
