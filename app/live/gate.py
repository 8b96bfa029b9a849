"""Exclusive access to the engine, shared by the stepping thread and the event loop.

The engine is synchronous and not thread-safe, and OMPL's random generator is global to the
process, so exactly one thread touches any mission at a time. The stepping thread holds the
gate for one short `advance` at a time; the event loop (commands, snapshots, frames,
fan-out, batching) takes it between those and always goes first: the stepper waits while
the loop wants in, so a request never waits for more than the chunk being stepped.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator
from types import TracebackType


class Gate:
    """A lock where the loop side has priority over the stepping thread."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._count = threading.Lock()
        self._wanted = 0
        self._free = threading.Event()
        self._free.set()

    def __enter__(self) -> Gate:
        """Loop side: wait for the current chunk to finish, then hold the engine."""
        with self._count:
            self._wanted += 1
            self._free.clear()
        self._lock.acquire()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._lock.release()
        with self._count:
            self._wanted -= 1
            if self._wanted == 0:
                self._free.set()

    @contextlib.contextmanager
    def stepping(self) -> Iterator[None]:
        """Stepper side: let any waiting loop-side user go first, then hold the engine."""
        self._free.wait()
        with self._lock:
            yield
