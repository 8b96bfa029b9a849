"""One operation per key at a time; concurrent callers share its outcome.

Resuming an interrupted mission builds an engine and replays it (seconds of work). Ten
concurrent resumes of one mission must not build ten engines and keep one: the first starts
the work, the others wait for that same work and get its result or its error.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable, Hashable
from typing import Generic, TypeVar

T = TypeVar("T")


class SingleFlight(Generic[T]):
    """`run(key, fn)` starts `fn()` unless a run for `key` is in flight, then awaits it."""

    def __init__(self) -> None:
        self._flying: dict[Hashable, asyncio.Task[T]] = {}

    def busy(self, key: Hashable) -> bool:
        return key in self._flying

    async def run(self, key: Hashable, fn: Callable[[], Awaitable[T]]) -> T:
        task = self._flying.get(key)
        if task is None:
            task = asyncio.ensure_future(fn())
            self._flying[key] = task
            task.add_done_callback(lambda t: self._landed(key, t))
        # shield: one caller going away (a dropped connection) must not cancel the others' work
        return await asyncio.shield(task)

    def _landed(self, key: Hashable, task: asyncio.Task[T]) -> None:
        self._flying.pop(key, None)
        if not task.cancelled():
            task.exception()  # retrieved: every caller may have gone away before it ended
