"""The one write path: every database write runs here, on a single writer thread.

One thread keeps SQLite free of writer contention. Operator actions and status changes go
ahead of queued event batches (`URGENT`), and batches are written in transactions of at
most `CHUNK_ROWS` events, so an operator waits for at most one small transaction; that
reordering is safe because a batch queued earlier only holds events from before the action.
For a SQLite file the WAL is checkpointed by a separate thread, never inside a commit
(`app/db/wal.py`).
Reads use the shared thread pool with their own sessions (WAL lets them run beside the
writer).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import queue
import threading
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from time import perf_counter
from typing import Any, TypeVar, cast

from sqlalchemy import Insert, Table, case, func, insert, select, update
from sqlalchemy.orm import Session, sessionmaker
from starlette.concurrency import run_in_threadpool

from app.db.models import (
    Action,
    Auction,
    Award,
    Base,
    Bid,
    Event,
    FieldLink,
    Mission,
    Pose,
    Sweep,
    utcnow,
)
from app.live.recorder import Batch, Stored

T = TypeVar("T")

log = logging.getLogger("regolith.store")

LIVE_STATUSES = ("running", "paused")
SWEEP_ACTIVE = ("running", "cancelling")
URGENT, BULK = 0, 1
CHUNK_ROWS = 100
_STOP = (2, 0, None, None)


class Store:
    """Async facade over a sessionmaker; writes are serialized on one thread."""

    def __init__(self, sessions: sessionmaker[Session]) -> None:
        self._sessions = sessions
        self._queue: queue.PriorityQueue[tuple[int, int, Any, Any]] = queue.PriorityQueue()
        self._order = itertools.count()
        self.writes = self.failures = 0
        self.write_seconds = self.write_max = 0.0
        self._thread = threading.Thread(target=self._work, name="regolith-db", daemon=True)
        self._thread.start()

    def _work(self) -> None:
        while True:
            _, _, job, done = self._queue.get()
            if job is None:
                return
            start = perf_counter()
            try:
                with self._sessions.begin() as session:
                    result = job(session)
            except BaseException as exc:  # handed to the awaiting coroutine
                self.failures += 1
                done(None, exc)
            else:
                done(result, None)
            took = perf_counter() - start
            self.writes += 1
            self.write_seconds += took
            self.write_max = max(self.write_max, took)

    @property
    def queued(self) -> int:
        """Writes waiting for the writer thread."""
        return self._queue.qsize()

    async def _write(self, fn: Callable[..., T], *args: Any, priority: int = URGENT) -> T:
        return await self._submit(fn, *args, priority=priority)

    def _submit(self, fn: Callable[..., T], *args: Any, priority: int) -> asyncio.Future[T]:
        """Queue `fn(session, *args)` for the writer; the future settles on the loop."""
        loop = asyncio.get_running_loop()
        future: asyncio.Future[T] = loop.create_future()

        def settle(result: Any, exc: BaseException | None) -> None:
            def apply() -> None:
                if future.done():
                    return
                if exc is not None:
                    future.set_exception(exc)
                else:
                    future.set_result(result)

            loop.call_soon_threadsafe(apply)

        self._queue.put((priority, next(self._order), partial(_call, fn, args), settle))
        return future

    async def read(self, fn: Callable[..., T], *args: Any) -> T:
        """Run `fn(session, *args)` on the thread pool with a fresh read session."""

        def _run() -> T:
            with self._sessions() as session:
                return fn(session, *args)

        return await run_in_threadpool(_run)

    def read_now(self, fn: Callable[..., T], *args: Any) -> T:
        """`read` on the calling thread: for work that already runs on a thread of its own
        (an export's stream, page by page)."""
        with self._sessions() as session:
            return fn(session, *args)

    def close(self) -> None:
        """Finish every queued write, then stop the writer."""
        self._queue.put(_STOP)
        self._thread.join()

    # -- writes ------------------------------------------------------------------------

    async def create_mission(
        self, fields: dict[str, Any], field_link: dict[str, Any] | None = None
    ) -> Mission:
        """A new mission's row (and a field mission's link to its processes, in the same
        transaction: a field mission is never stored unreachable)."""
        return await self._write(_create_mission, fields, field_link)

    async def write(self, fn: Callable[..., T], *args: Any) -> T:
        """`fn(session, *args)` on the writer thread, urgent: the writes another module keeps
        with its reads (`app/services/field_links.py`)."""
        return await self._write(fn, *args)

    async def record_action(
        self, mission_id: int, action: dict[str, Any], replay: bool, changes: dict[str, Any]
    ) -> Action:
        """Commit an operator action (and the mission fields it changes) before answering."""
        return await self._write(_record_action, mission_id, action, replay, changes)

    async def write_batch(self, batch: Batch, changes: dict[str, Any] | None = None) -> None:
        """A live mission's new rows, in small transactions queued back to back (in order);
        a final batch (with `changes`) is urgent."""
        priority = URGENT if changes else BULK
        events = batch.events
        if batch.poses or (events and events[0].get("source") is not None):
            # a field run's: one transaction, so what is stored of each process life is
            # always a prefix of what it reported (a restarted server reads on from there)
            await self._submit(_write_batch, batch, changes or {}, priority=priority)
            return
        parts = [
            self._submit(_insert_events, events[i : i + CHUNK_ROWS], priority=priority)
            for i in range(0, len(events) - CHUNK_ROWS, CHUNK_ROWS)
        ]
        rest = replace(batch, events=events[len(parts) * CHUNK_ROWS :])
        parts.append(self._submit(_write_batch, rest, changes or {}, priority=priority))
        for part in parts:
            await part

    async def interrupt_stale(self, keep: frozenset[int] = frozenset()) -> int:
        """Missions left running by a crash cannot be live now: mark them interrupted (all
        but `keep`, the field missions attached to again)."""
        return await self._write(_interrupt_stale, keep)

    async def create_sweep(self, fields: dict[str, Any]) -> Sweep:
        return await self._write(_create_sweep, fields)

    async def update_sweep(
        self, sweep_id: int, changes: dict[str, Any], urgent: bool = True
    ) -> None:
        """A sweep's status (urgent) or its progress (bulk: it may wait behind event batches)."""
        await self._write(_update_sweep, sweep_id, changes, priority=URGENT if urgent else BULK)

    async def interrupt_stale_sweeps(self) -> int:
        """Sweeps left running by a stop or crash have no job now: mark them interrupted."""
        return await self._write(_interrupt_stale_sweeps)


def _call(fn: Callable[..., T], args: tuple[Any, ...], session: Session) -> T:
    return fn(session, *args)


def _create_mission(
    session: Session, fields: dict[str, Any], field_link: dict[str, Any] | None
) -> Mission:
    row = Mission(created_at=utcnow(), **fields)
    session.add(row)
    session.flush()
    if field_link is not None:
        session.add(FieldLink(mission_id=row.id, **field_link))
    return row


def _record_action(
    session: Session, mission_id: int, action: dict[str, Any], replay: bool, changes: dict[str, Any]
) -> Action:
    last = session.scalar(select(func.max(Action.seq)).where(Action.mission_id == mission_id))
    row = Action(
        mission_id=mission_id,
        seq=0 if last is None else last + 1,
        t=float(action["t"]),
        kind=str(action["kind"]),
        args=dict(action.get("args") or {}),
        replay=replay,
        created_at=utcnow(),
    )
    session.add(row)
    if changes:
        _update_mission(session, mission_id, changes)
    return row


def _core(model: type[Base]) -> Insert:
    """A Core INSERT on the model's table: plain executemany, cheaper than ORM bulk inserts."""
    return insert(cast(Table, model.__table__))


def _insert_events(session: Session, rows: list[dict[str, Any]]) -> None:
    session.execute(_core(Event), rows)


def _write_batch(session: Session, batch: Batch, changes: dict[str, Any]) -> None:
    if batch.events:
        session.execute(_core(Event), batch.events)
    if batch.new_auctions:
        session.execute(_core(Auction), batch.new_auctions)
    if batch.changed_auctions:
        session.execute(update(Auction), batch.changed_auctions)
    if batch.bids:
        session.execute(_core(Bid), batch.bids)
    if batch.awards:
        session.execute(_core(Award), batch.awards)
    if batch.changed_awards:
        session.execute(update(Award), batch.changed_awards)
    if batch.poses:
        session.execute(_core(Pose), batch.poses)
    latest = case((Mission.sim_time < batch.sim_time, batch.sim_time), else_=Mission.sim_time)
    _update_mission(session, batch.mission_id, {"sim_time": latest, **changes})


def _update_mission(session: Session, mission_id: int, changes: dict[str, Any]) -> None:
    session.execute(update(Mission).where(Mission.id == mission_id).values(**changes))


def _interrupt_stale(session: Session, keep: frozenset[int]) -> int:
    result = session.execute(
        update(Mission)
        .where(Mission.status.in_(LIVE_STATUSES), Mission.id.not_in(keep))
        .values(status="interrupted")
    )
    return int(getattr(result, "rowcount", 0) or 0)


def _create_sweep(session: Session, fields: dict[str, Any]) -> Sweep:
    row = Sweep(created_at=utcnow(), **fields)
    session.add(row)
    session.flush()
    return row


def _update_sweep(session: Session, sweep_id: int, changes: dict[str, Any]) -> None:
    session.execute(update(Sweep).where(Sweep.id == sweep_id).values(**changes))


def _interrupt_stale_sweeps(session: Session) -> int:
    result = session.execute(
        update(Sweep)
        .where(Sweep.status.in_(SWEEP_ACTIVE))
        .values(status="interrupted", eta_s=None, ended_at=utcnow())
    )
    return int(getattr(result, "rowcount", 0) or 0)


def stored_counts(session: Session, mission_id: int) -> Stored:
    """How much of a mission's log is already stored (to continue it after a replay)."""
    events = session.scalar(select(func.count()).where(Event.mission_id == mission_id)) or 0
    bids = session.execute(
        select(Bid.auction_id, func.count())
        .where(Bid.mission_id == mission_id)
        .group_by(Bid.auction_id)
    ).all()
    awards = session.execute(
        select(Award.auction_id, Award.outcome)
        .where(Award.mission_id == mission_id)
        .order_by(Award.auction_id, Award.idx)
    ).all()
    auctions = session.scalars(select(Auction.auction_id).where(Auction.mission_id == mission_id))
    stored = Stored(events=int(events))
    for aid in auctions:
        stored.bids[aid] = 0
        stored.awards[aid] = []
    stored.bids.update({aid: int(n) for aid, n in bids})
    for aid, outcome in awards:
        stored.awards[aid].append(outcome)
    return stored
