"""Live-mission places: checked and taken in one step, before the first await.

Creating or reviving a mission awaits (building the engine, replaying, the first commit)
before the runner counts it as live. A check made before those awaits and trusted after
them lets every concurrent request through; so a request takes a place here synchronously
(nothing else runs on the event loop between the check and the take) and gives it back once
the runner counts the mission, or once it failed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from app.services.errors import LimitExceeded


class ProcessBudget:
    """Field missions' agent processes, server-wide: each robot of a field mission is an OS
    process (~110 MB, and a share of the CPU), so robots count here, not only against the
    per-mission robot limit. `reserve` holds processes being started (a mission's team)
    until the runner counts them; `check` is for one started at once under the gate."""

    def __init__(self, limit: int, in_use: Callable[[], int]) -> None:
        self.limit = limit
        self._in_use = in_use
        self.pending = 0

    def check(self, n: int) -> None:
        used = self._in_use() + self.pending
        if used + n > self.limit:
            raise LimitExceeded(
                f"field_processes: {n} more agent process{'es' if n != 1 else ''} would make "
                f"{used + n}, over the server's budget of {self.limit} "
                "(REGOLITH_FIELD_PROCESSES); stop a field mission or raise the budget"
            )

    @contextmanager
    def reserve(self, n: int) -> Iterator[None]:
        self.check(n)
        self.pending += n
        try:
            yield
        finally:
            self.pending -= n


class Admission:
    """At most `limit` missions live or on their way to being live."""

    def __init__(self, limit: int, live: Callable[[], int]) -> None:
        self.limit = limit
        self._live = live
        self.pending = 0

    @contextmanager
    def place(self, refusal: str) -> Iterator[None]:
        """Hold a place for the duration of the block, or raise LimitExceeded(refusal).

        Leave the block only once the mission is in the runner's registry (or has failed):
        until then it is counted here, after that there.
        """
        if self._live() + self.pending >= self.limit:
            raise LimitExceeded(refusal)
        self.pending += 1
        try:
            yield
        finally:
            self.pending -= 1
