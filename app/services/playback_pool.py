"""The playback pool: replay engines parked at times of their missions (runs in the playback
worker process, `app/services/playback_worker.py`; the server talks to it through
`app/services/playback.py`).

A mission is a pure function of its scenario, seed, planner and replayable operator actions,
so the state at time `t` is what a fresh engine shows after replaying the actions up to `t`
and advancing to `t`. Replaying from zero on every scrub would cost a whole run each time,
and an engine cannot be copied (its robots are simpy processes, i.e. generators, which
neither `copy` nor `pickle` can take), so the checkpoints are engines themselves: *cursors*
parked at the time they last showed. A request takes the parked cursor of that mission
closest before `t` and advances it (playing forward costs only the simulated span between
two requests); only a step back past every cursor starts a new one from zero. The pool is
bounded (`REGOLITH_PLAYBACK_CURSORS` engines in all, at most `REGOLITH_PLAYBACK_PER_MISSION`
per mission; within a mission the survivors stay spread over the timeline, across missions
the least recently used go first: `app/services/cursors.py`). After a request the pool also
builds *checkpoints* for that mission in the background, at the middle of the widest stretch
of its timeline no cursor covers, until no stretch is wider than the timeline divided by the
per-mission limit less one (a quarter, by default): a scrub anywhere then replays at most that
much, and a scrub that carries a checkpoint away leaves room for it to be rebuilt.
Checkpoints go only into free room and within the mission's share of the pool (`share`), so
they never evict a cursor: many missions' builders once evicted one another's checkpoints and
rebuilt them for ever. Every few closed engines a full collection frees their reference
cycles at once (the worker's heap holds nothing else, so it is quick).

Replay work runs on threads in short slices under the process's own engine gate (OMPL's random
generator is global to a process: one engine at a time), so the worker's event loop keeps
reading requests meanwhile. A cursor is checked out while it works: two viewers scrubbing one
mission never share an engine.
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import itertools
import time
from dataclasses import dataclass, field
from time import perf_counter
from typing import Any

from app.live.gate import Gate
from app.live.records import auction_dict, stream_state
from app.services.cursors import evictions, gap_to_fill, pick
from app.services.errors import Conflict
from engine import Mission, parse_scenario
from engine.mission import PLANNERS

#: Auctions sent with a state: the latest opened by `t` (as the live feed loads), plus any
#: older one still open at `t`.
FEED_AUCTIONS = 200
_SLICE_S = 0.005
#: Requests replaying at once (the rest wait their turn), so a burst of scrubs cannot build
#: engines beyond the pool's bound; checkpoints are built one at a time, apart from them.
WORKERS = 2
_YIELD_S = 0.002
#: the playhead and one checkpoint: what a mission may fill up to whatever its share
MIN_SHARE = 3
#: closed engines between full collections (an engine is full of reference cycles)
COLLECT_EVERY = 4
_EPS = 1e-9


@dataclass(frozen=True)
class Spec:
    """What determines a mission's replay (its actions aside), as the server sends it."""

    id: int
    scenario: dict[str, Any]
    seed: int
    policy: str
    planner: str


@dataclass(eq=False)
class Cursor:
    """A replay engine parked at `engine.now`, with how far it has read its own log."""

    mission_id: int
    engine: Mission
    applied: int = 0  # replayable actions applied so far
    scanned: int = 0  # events looked through for deliveries
    deliveries: list[dict[str, Any]] = field(default_factory=list)
    used: int = 0

    @property
    def at(self) -> float:
        return self.engine.now


class Closing(Exception):
    """The worker is stopping: replay work in flight gives up."""


class Pool:
    """The pool of replay cursors, shared by every viewer of every mission."""

    def __init__(self, capacity: int, per_mission: int) -> None:
        self.gate = Gate()  # this process's engines, one at a time
        self.capacity = capacity
        self.per_mission = per_mission
        self._parked: list[Cursor] = []
        self._clock = itertools.count(1)
        self._fills: dict[int, asyncio.Task[None]] = {}
        self._closing = False
        self._workers = asyncio.Semaphore(WORKERS)
        self._filler = asyncio.Semaphore(1)
        self._asking = 0  # requests waiting or replaying: checkpoint building pauses for them
        self._out = 0  # cursors checked out by requests (they come back to the pool)
        self.built = 0  # cursors started from zero (for tests and the bench)
        self.closed = 0  # engines closed (evicted, failed, or at shutdown)

    async def state_at(
        self, spec: Spec, actions: list[dict[str, Any]], t: float, end: float
    ) -> dict[str, Any]:
        """The state of mission `spec` at simulated time `t` (0 <= t <= `end`, checked by the
        server), as the route sends it; Conflict if the replay fails."""
        self._asking += 1
        try:
            async with self._workers:
                self._out += 1
                try:
                    cursor = await self._replay(spec, actions, t)
                    try:
                        out = await asyncio.to_thread(self._read, cursor)
                    finally:
                        self._checkin(cursor)
                finally:
                    self._out -= 1
        finally:
            self._asking -= 1
        self._fill_later(spec, actions, end)
        return out

    async def _replay(
        self, spec: Spec, actions: list[dict[str, Any]], t: float, background: bool = False
    ) -> Cursor:
        """A cursor of `spec` standing at `t`: the parked one latest before `t`, moved on, or
        a new one (checked out: the caller checks it back in)."""
        if self._closing:
            raise Conflict("the playback worker is stopping")
        cursor = pick(self._parked, spec.id, t)
        if cursor is not None:
            self._parked.remove(cursor)
        try:
            if cursor is None:
                cursor = await asyncio.to_thread(self._build, spec)
            await asyncio.to_thread(self._advance_with, cursor, actions, t, background)
        except Exception as exc:
            if cursor is not None:
                await asyncio.to_thread(self._close, cursor)
            if isinstance(exc, Closing):
                raise Conflict("the playback worker is stopping") from exc
            raise Conflict(f"mission {spec.id} cannot be replayed to t={t:g}: {exc}") from exc
        return cursor

    # -- the pool ----------------------------------------------------------------------

    def _checkin(self, cursor: Cursor) -> None:
        cursor.used = next(self._clock)
        self._parked.append(cursor)
        for c in evictions(self._parked, self.per_mission, self.capacity):
            self._parked.remove(c)
            self._close(c)

    def parked(self, mission_id: int | None = None) -> list[float]:
        """The times the parked cursors stand at (of one mission, or all)."""
        return sorted(c.at for c in self._parked if mission_id in (None, c.mission_id))

    def _fill_later(self, spec: Spec, actions: list[dict[str, Any]], end: float) -> None:
        """Build this mission's missing checkpoints in the background (one task a mission)."""
        if spec.id not in self._fills and not self._closing:
            task = asyncio.create_task(self._fill(spec, actions, end))
            self._fills[spec.id] = task
            task.add_done_callback(lambda _: self._fills.pop(spec.id, None))

    def share(self, mission_id: int) -> int:
        """How many cursors this mission may keep through checkpoints: its even share of the
        pool among the missions holding cursors (or building them), at most the per-mission
        limit, at least `MIN_SHARE` (a checkpoint at the middle; only into free room).
        Checkpoints of six missions wanting four each in a pool of ten would otherwise evict
        one another and be rebuilt for ever."""
        holders = {c.mission_id for c in self._parked} | set(self._fills) | {mission_id}
        return min(self.per_mission, max(MIN_SHARE, self.capacity // len(holders)))

    async def _fill(self, spec: Spec, actions: list[dict[str, Any]], end: float) -> None:
        """Checkpoints only into free room, within the mission's share, and at most
        `per_mission` builds a run: a checkpoint never evicts another cursor, so this ends."""
        for _ in range(self.per_mission):
            if self._room() <= 0:
                return
            at = gap_to_fill(self.parked(spec.id), end, self.share(spec.id))
            if at is None:
                return
            async with self._filler:
                try:
                    cursor = await self._replay(spec, actions, at, background=True)
                except Conflict:
                    return
                if self._room() <= 0:  # requests filled the pool meanwhile: theirs goes first
                    await asyncio.to_thread(self._close, cursor)
                    return
                self._checkin(cursor)

    def _room(self) -> int:
        """Free slots in the pool (parked cursors count, checked-out ones will come back)."""
        return self.capacity - len(self._parked) - self._out

    def stats(self) -> dict[str, int]:
        """The pool's counts, as the server shows them in `/api/metrics`."""
        return {
            "engines": self.built - self.closed,
            "fills": len(self._fills),
            "built": self.built,
            "closed": self.closed,
            "parked": len(self._parked),
        }

    @property
    def checked_out(self) -> int:
        """Cursors working for requests now."""
        return self._out

    @property
    def fills(self) -> int:
        """Missions whose checkpoints are being built now."""
        return len(self._fills)

    async def aclose(self) -> None:
        """Stop building checkpoints and close every parked engine (the worker is stopping)."""
        self._closing = True
        for task in list(self._fills.values()):
            with contextlib.suppress(Exception):
                await task
        while self._parked:
            self._close(self._parked.pop())

    # -- engine work (worker thread, short holds of the gate) ---------------------------

    def _close(self, cursor: Cursor) -> None:
        """Close an engine; every `COLLECT_EVERY` a full collection frees the closed ones'
        reference cycles at once, so the garbage stays within a few engines."""
        with self.gate:
            cursor.engine.close()
        self.closed += 1
        if self.closed % COLLECT_EVERY == 0:
            gc.collect()

    def _build(self, spec: Spec) -> Cursor:
        planner = spec.planner if spec.planner in PLANNERS else "ompl"  # as a resume does
        with self.gate:
            m = Mission(parse_scenario(spec.scenario), spec.seed, spec.policy, planner=planner)  # type: ignore[arg-type]
        self.built += 1
        return Cursor(spec.id, m)

    def _advance(self, m: Mission, t: float, background: bool = False) -> None:
        """Advance in slices of about 5 ms, each taking the gate as a stepping thread does
        (after any reader), so replays for two requests take turns; a checkpoint being built
        (in the background) also waits between slices while any request is replaying."""
        chunk = 1.0
        while m.now < t and not m.done:
            while background and self._asking and not self._closing:
                time.sleep(_YIELD_S)
            if self._closing:
                raise Closing
            t0 = perf_counter()
            with self.gate.stepping():  # the stepper's side: requests and commands go first
                m.advance(min(t, m.now + chunk))
            took = perf_counter() - t0
            chunk = chunk * 2 if took < _SLICE_S / 4 else max(chunk / 2, 1e-3)
            time.sleep(0)  # and the other replay gets its turn between slices
        with self.gate:
            m.advance(t)  # events at exactly `t` too, even when the engine already stands there

    def _advance_with(
        self, cursor: Cursor, actions: list[dict[str, Any]], t: float, background: bool = False
    ) -> None:
        """Replay `cursor` to `t`, every action and event at `t` included."""
        m = cursor.engine
        while cursor.applied < len(actions) and float(actions[cursor.applied]["t"]) <= t:
            action = actions[cursor.applied]
            self._advance(m, float(action["t"]), background)
            with self.gate:
                m.apply(action)
            cursor.applied += 1
        self._advance(m, t, background)

    def _read(self, cursor: Cursor) -> dict[str, Any]:
        """The cursor's snapshot, its latest auctions, its deliveries and its event count."""
        m = cursor.engine
        with self.gate:
            state = stream_state(m.snapshot())
            records = m.auctions
            older = [a for a in records[:-FEED_AUCTIONS] if a.status == "open"]
            auctions = [auction_dict(a.to_dict()) for a in older + records[-FEED_AUCTIONS:]]
            log = m.events
            for ev in log[cursor.scanned :]:
                if ev.kind == "delivered":
                    cursor.deliveries.append(ev.to_dict())
            cursor.scanned = len(log)
            assert state is not None
            return {
                "state": state,
                "auctions": auctions,
                "deliveries": list(cursor.deliveries),
                "events": len(log),
            }
