"""Mission playback: a mission exactly as it was at any simulated time, rebuilt by replay.

The replay engines run in a worker process of their own (`app/services/playback_worker.py`,
the pool itself in `app/services/playback_pool.py`, the server's handle on the process in
`app/services/playback_handle.py`), not in the server. A replay engine is megabytes of small
objects; in the server, while a mission is live, the live engine's ever-growing log landed
in the same allocator arenas as the replays' short-lived objects and kept those arenas from
going back to the system: after a burst of scrubs the server stayed ~200 MB above its start
for good. The worker's heap holds nothing but the pool, and the server stops the worker once
playback has been idle for `REGOLITH_PLAYBACK_IDLE_S`, which gives all of it back; the next
scrub starts a new one (a second or two to import the engine).

Here: the checks a request needs the database for (404, 422 past the end), the replayable
actions (a live mission's from its engine, so an action just applied counts before it is
committed), and the worker's life. A field run is never replayed: its moments are read from
its stored poses and events (`app/services/field_playback.py`). Concurrent requests for the same
moment of a mission share one answer; at most `IN_FLIGHT` requests are with the worker at a
time and at most `REGOLITH_PLAYBACK_QUEUE` wait in all (429 beyond). A worker that dies
(killed, crashed, or sent a malformed or oversized frame) answers every request it held with
503 saying what happened, and the next request starts a new one.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from time import monotonic
from typing import Any

from sqlalchemy.orm import Session

import app
from app.db.models import Mission as MissionRow
from app.live.gate import Gate
from app.services import field_playback
from app.services.errors import Invalid, LimitExceeded, Unavailable
from app.services.live_state import LiveState
from app.services.missions import MissionService
from app.services.playback_handle import Worker
from app.services.playback_pool import WORKERS
from app.services.singleflight import SingleFlight
from app.settings import Settings

__all__ = ["WORKERS", "Playback", "StateAt"]

#: Requests with the worker at once (the rest wait here): enough to keep its two replays and
#: the next ones busy, few enough that the worker holds little besides its engines.
IN_FLIGHT = 2 * WORKERS
_EPS = 1e-9


@dataclass(frozen=True)
class StateAt:
    """A mission at simulated time `t` (the answer of `GET /api/missions/{id}/state`)."""

    t: float
    end: float
    row: MissionRow
    live: LiveState | None
    state: dict[str, Any]
    auctions: list[dict[str, Any]]
    deliveries: list[dict[str, Any]]
    events: int


class Playback:
    """Answers `state?t=` through the playback worker, which it starts, watches and stops."""

    def __init__(self, settings: Settings, missions: MissionService) -> None:
        self.missions = missions
        self.gate: Gate = missions.gate
        self.capacity = settings.playback_cursors
        self.per_mission = settings.playback_per_mission
        self.idle_s = settings.playback_idle_s
        self.queue_cap = settings.playback_queue
        self._flights: SingleFlight[dict[str, Any]] = SingleFlight()
        self._forward = asyncio.Semaphore(IN_FLIGHT)
        self._life = asyncio.Lock()  # a worker starts or stops one at a time
        self._worker: Worker | None = None
        self._watchers: set[asyncio.Task[None]] = set()
        self._closing = False
        self.queued = 0  # requests waiting here or with the worker
        self._last_busy = monotonic()
        self.starts = 0  # workers started (metrics)
        self._gone_built = 0  # engines of ended workers (all closed with them)
        self.loop = asyncio.get_running_loop()

    # -- requests ------------------------------------------------------------------------

    async def state_at(self, mission_id: int, t: float) -> StateAt:
        """The state of mission `mission_id` at simulated time `t` (404 unknown, 422 `t`
        past the mission's time, 409 if its replay fails, 429 when too many scrubs wait, 503
        if the worker dies meanwhile). A field run is read from its stored poses and events
        instead (`app/services/field_playback.py`): it cannot be re-simulated."""
        row, live = await self.missions.detail(mission_id)
        end = live.sim_time if live is not None else row.sim_time
        if t > end + _EPS:
            raise Invalid(
                f"t: {t:g} is past the end of mission {mission_id} (simulated time {end:g})",
                ("query", "t"),
            )
        if row.mode == "field":
            return await self._field(row, live, t, end)
        actions = self._actions(mission_id, row)
        upto = sum(1 for a in actions if float(a["t"]) <= t)
        request = {
            "op": "state",
            "mission": {
                "id": row.id,
                "scenario": row.scenario,
                "seed": row.seed,
                "policy": row.policy,
                "planner": row.planner,
            },
            "actions": actions,
            "t": t,
            "end": end,
        }
        # the same moment asked twice at once (the same actions up to it): one replay
        out = await self._flights.run((mission_id, t, upto), lambda: self._ask(request))
        return StateAt(
            t, end, row, live, out["state"], out["auctions"], out["deliveries"], out["events"]
        )

    async def _field(
        self, row: MissionRow, live: LiveState | None, t: float, end: float
    ) -> StateAt:
        """A field run at `t`, from the database alone (live too: stored up to now)."""
        ended = live is None and t >= end - _EPS
        mission = {
            "status": row.status if ended else "running",
            "policy": row.policy,
            "scenario": row.scenario_name,
            "seed": row.seed,
        }
        world = row.world_map or {}

        def read(session: Session) -> dict[str, Any]:
            return field_playback.moment(
                field_playback.read_stored(session, row.id, t), t, mission, world
            )

        out = await self.missions.store.read(read)
        return StateAt(
            t, end, row, live, out["state"], out["auctions"], out["deliveries"], out["events"]
        )

    def _actions(self, mission_id: int, row: MissionRow) -> list[dict[str, Any]]:
        """The replayable actions in order: the live engine's own list while it runs (an
        action is there the moment it applies, before it is committed), else the stored."""
        lm = self.missions.runner.live.get(mission_id)
        if lm is not None and not lm.finishing:
            with self.gate:
                return [dict(a) for a in lm.mission.actions]
        stored = sorted((a for a in row.actions if a.replay), key=lambda a: a.seq)
        return [{"t": a.t, "kind": a.kind, "args": a.args} for a in stored]

    async def _ask(self, request: dict[str, Any]) -> dict[str, Any]:
        if self.queued >= self.queue_cap:
            raise LimitExceeded(
                f"{self.queued} scrubs are already waiting for playback, the most allowed "
                "(REGOLITH_PLAYBACK_QUEUE); try again shortly"
            )
        self.queued += 1
        try:
            async with self._forward:
                worker = await self._running()
                return await worker.ask(request)
        finally:
            self.queued -= 1
            self._last_busy = monotonic()

    # -- the worker's life -----------------------------------------------------------------

    async def _running(self) -> Worker:
        """The live worker, started if there is none (or the last one ended)."""
        async with self._life:
            if self._closing:
                raise Unavailable("the server is stopping")
            w = self._worker
            if w is None or w.gone is not None:
                w = self._worker = await self._start()
            return w

    async def _start(self) -> Worker:
        root = str(Path(app.__file__).resolve().parent.parent)  # this very code, wherever run
        path = os.environ.get("PYTHONPATH")
        env = {**os.environ, "PYTHONPATH": root + (os.pathsep + path if path else "")}
        proc = await asyncio.create_subprocess_exec(
            sys.executable,
            "-m",
            "app.services.playback_worker",
            "--cursors",
            str(self.capacity),
            "--per-mission",
            str(self.per_mission),
            stdin=asyncio.subprocess.PIPE,
            stdout=asyncio.subprocess.PIPE,
            env=env,
            limit=2**20,
        )
        w = Worker(proc)
        self.starts += 1
        w.done.add_done_callback(lambda _: self._ended(w))
        self._last_busy = monotonic()
        watcher = asyncio.create_task(self._watch_idle(w))
        self._watchers.add(watcher)
        watcher.add_done_callback(self._watchers.discard)
        return w

    def _ended(self, w: Worker) -> None:
        self._gone_built += w.stats["built"]
        if self._worker is w:
            self._worker = None

    async def _watch_idle(self, w: Worker) -> None:
        """Stop `w` once no request has waited and no checkpoint been built for `idle_s`."""
        while w.gone is None:
            await asyncio.sleep(min(1.0, self.idle_s / 4))
            if self.queued or w.pending or w.stats["fills"]:
                self._last_busy = monotonic()
            elif monotonic() - self._last_busy >= self.idle_s:
                async with self._life:
                    if not self.queued and not w.pending and w.gone is None:
                        await w.stop(f"was stopped after {self.idle_s:g} s idle")

    async def stop_worker(self, why: str) -> None:
        """Stop the worker now, if there is one (shutdown; the memory bench)."""
        async with self._life:
            if self._worker is not None and self._worker.gone is None:
                await self._worker.stop(why)

    async def aclose(self) -> None:
        """Stop the worker (the server is stopping): no process outlives the server."""
        self._closing = True
        await self.stop_worker("was stopped with the server")
        for watcher in list(self._watchers):
            watcher.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await watcher

    # -- what the metrics show -------------------------------------------------------------

    @property
    def worker_pid(self) -> int | None:
        w = self._worker
        return w.pid if w is not None and w.gone is None else None

    @property
    def built(self) -> int:
        """Replay engines started from zero, by every worker so far."""
        w = self._worker
        return self._gone_built + (w.stats["built"] if w is not None else 0)

    @property
    def closed(self) -> int:
        """Replay engines closed (an ended worker's all are)."""
        w = self._worker
        return self._gone_built + (w.stats["closed"] if w is not None else 0)

    @property
    def fills(self) -> int:
        """Missions whose checkpoints are being built now."""
        w = self._worker
        return w.stats["fills"] if w is not None else 0

    def worker_rss(self) -> int:
        """The worker's resident memory in bytes (0 without one; Linux's /proc)."""
        pid = self.worker_pid
        if pid is None:
            return 0
        try:
            pages = int(Path(f"/proc/{pid}/statm").read_text().split()[1])
        except (OSError, ValueError, IndexError):
            return 0
        return pages * os.sysconf("SC_PAGE_SIZE")
