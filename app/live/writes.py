"""Live missions' records, written in the background while the event loop goes on.

Each mission's writes are chained (a batch may update auctions the previous one inserts), and
each is a bulkhead: a batch the mission's own data spoils ends that mission alone as failed,
its final record written even so, with the reason.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Coroutine
from time import perf_counter
from typing import Any, Protocol

from app.live.mission import LiveMission
from app.live.recorder import Batch
from app.live.records import describe, failed_record

log = logging.getLogger("regolith.runner")


class BatchWriter(Protocol):
    """Where live missions' records go (`app.services.store.Store`)."""

    async def write_batch(self, batch: Batch, changes: dict[str, Any] | None = None) -> None: ...


def safe_now(lm: LiveMission) -> float:
    """The mission's time, or 0 if its engine cannot tell (a record is written even so)."""
    try:
        return float(lm.mission.now)
    except Exception:
        return 0.0


class MissionWrites:
    """The background writes of every live mission, each awaited by `drain`."""

    def __init__(self, store: BatchWriter) -> None:
        self.store = store
        self._pending: set[asyncio.Task[Any]] = set()

    async def drain(self) -> None:
        while self._pending:
            await asyncio.gather(*list(self._pending), return_exceptions=True)

    def spawn(self, coro: Coroutine[Any, Any, None]) -> asyncio.Task[None]:
        """Run `coro` in the background; `drain` waits for it too."""
        task = asyncio.create_task(coro)
        self._pending.add(task)
        task.add_done_callback(self._done)
        return task

    def _done(self, task: asyncio.Task[Any]) -> None:
        self._pending.discard(task)
        if not task.cancelled() and task.exception() is not None:
            log.error("background write failed", exc_info=task.exception())

    def write(self, lm: LiveMission, changes: dict[str, Any] | None = None) -> asyncio.Task[None]:
        """Write what `lm` produced since the last write (the caller holds the gate), after
        that write. A batch that cannot be collected or that the database refuses: with
        `changes` (a final record), the record is written failed with the reason; without,
        the collection error is raised, or `lm.crashed` is set for the runner to end it."""
        try:
            batch = lm.recorder.collect()
        except Exception as exc:
            if changes is None:
                raise  # the caller ends the mission (`quarantine`), with this final write
            log.exception("mission %s: records not collected", lm.id, extra={"mission_id": lm.id})
            changes = failed_record(changes, f"records not collected: {describe(exc)}")
            batch = Batch(lm.id, safe_now(lm))
        previous = lm.writing
        lm.last_flush = perf_counter()

        async def write() -> None:
            if previous is not None:
                with contextlib.suppress(Exception):
                    await previous
            try:
                await self.store.write_batch(batch, changes)
            except Exception as exc:
                reason = f"records refused by the database: {describe(exc)}"
                log.exception("mission %s: %s", lm.id, reason, extra={"mission_id": lm.id})
                if changes is None:
                    lm.crashed = lm.crashed or reason  # the runner's upkeep ends it, alone
                    return
                await self.store.write_batch(
                    Batch(lm.id, batch.sim_time), failed_record(changes, reason)
                )

        lm.writing = self.spawn(write())
        return lm.writing
