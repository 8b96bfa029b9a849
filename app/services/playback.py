"""Mission playback: a mission exactly as it was at any simulated time, rebuilt by replay.

The replay engines run in a worker process of their own (`app/services/playback_worker.py`,
the pool itself in `app/services/playback_pool.py`), not in the server. A replay engine is
megabytes of small objects; in the server, while a mission is live, the live engine's
ever-growing log landed in the same allocator arenas as the replays' short-lived objects and
kept those arenas from going back to the system: after a burst of scrubs the server stayed
~200 MB above its start for good. The worker's heap holds nothing but the pool, and the
server stops the worker once playback has been idle for `REGOLITH_PLAYBACK_IDLE_S`, which
gives all of it back; the next scrub starts a new one (a second or two to import the engine).

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
import itertools
import os
import signal
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
from app.services.errors import Conflict, Invalid, LimitExceeded, Unavailable
from app.services.live_state import LiveState
from app.services.missions import MissionService
from app.services.playback_pool import WORKERS
from app.services.playback_wire import WireError, encode, read_frame
from app.services.singleflight import SingleFlight
from app.settings import Settings

__all__ = ["WORKERS", "Playback", "StateAt"]

#: Requests with the worker at once (the rest wait here): enough to keep its two replays and
#: the next ones busy, few enough that the worker holds little besides its engines.
IN_FLIGHT = 2 * WORKERS
#: How long a worker told to stop may take before it is killed.
STOP_S = 10.0
_EPS = 1e-9
_STATS = ("engines", "fills", "built", "closed", "parked")


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


def _checked_answer(ok: Any) -> dict[str, Any]:
    """The worker's answer, if it has the shape of one (else WireError)."""
    if not (
        isinstance(ok, dict)
        and isinstance(ok.get("state"), dict)
        and isinstance(ok.get("auctions"), list)
        and isinstance(ok.get("deliveries"), list)
        and type(ok.get("events")) is int
    ):
        raise WireError("an answer without state, auctions, deliveries and events")
    return ok


def _checked_stats(stats: Any) -> dict[str, int]:
    if not (isinstance(stats, dict) and all(type(stats.get(k)) is int for k in _STATS)):
        raise WireError("counts without " + ", ".join(_STATS))
    return {k: stats[k] for k in _STATS}


def _how(code: int) -> str:
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"was killed by {signal.Signals(-code).name}"
        return f"was killed by signal {-code}"
    return f"exited with status {code}"


class Worker:
    """One worker process and the requests it holds; `gone` says why it ended, once it has."""

    def __init__(self, proc: asyncio.subprocess.Process) -> None:
        self.proc = proc
        self.pid = proc.pid
        self.pending: dict[int, asyncio.Future[dict[str, Any]]] = {}
        self.stats = dict.fromkeys(_STATS, 0)
        self.gone: str | None = None
        self._stopping: str | None = None
        self._ids = itertools.count(1)
        self._write = asyncio.Lock()
        self.done = asyncio.create_task(self._read())

    async def ask(self, message: dict[str, Any]) -> dict[str, Any]:
        """Send one request and wait for its answer (Conflict, or Unavailable if it dies)."""
        if self.gone is not None:
            raise Unavailable(f"the playback worker (pid {self.pid}) {self.gone}; try again")
        rid = next(self._ids)
        try:
            frame = encode({**message, "id": rid})
        except WireError as exc:  # a mission with more actions than a frame holds
            raise Conflict(f"this mission cannot be played back: {exc}") from exc
        future: asyncio.Future[dict[str, Any]] = asyncio.get_running_loop().create_future()
        self.pending[rid] = future
        try:
            async with self._write:
                assert self.proc.stdin is not None
                # a dead worker's pipe refuses (ConnectionError, or RuntimeError once asyncio has
                # closed it): `_read` answers the future with why it died
                with contextlib.suppress(ConnectionError, RuntimeError):
                    self.proc.stdin.write(frame)
                    await self.proc.stdin.drain()
            return await future
        finally:
            self.pending.pop(rid, None)

    async def stop(self, why: str) -> None:
        """Ask the worker to stop, kill it if it has not within `STOP_S`; wait for its end."""
        self._stopping = why
        assert self.proc.stdin is not None
        with contextlib.suppress(ConnectionError, RuntimeError):
            self.proc.stdin.write(encode({"op": "stop"}))
            self.proc.stdin.close()
        try:
            await asyncio.wait_for(asyncio.shield(self.done), STOP_S)
        except TimeoutError:
            with contextlib.suppress(ProcessLookupError):
                self.proc.kill()
            await self.done

    async def _read(self) -> None:
        """Take frames until the worker's stdout ends; then fail whatever it still held."""
        assert self.proc.stdout is not None
        why = None
        try:
            while (msg := await read_frame(self.proc.stdout)) is not None:
                self._take(msg)
        except Exception as exc:  # WireError, or anything a broken frame could cause in `_take`
            why = f"sent a malformed frame ({exc}) and was stopped"
            with contextlib.suppress(ProcessLookupError):
                self.proc.kill()
        code = await self.proc.wait()
        self.gone = self._stopping or why or _how(code)
        self.stats["engines"] = self.stats["fills"] = self.stats["parked"] = 0
        for future in self.pending.values():
            if not future.done():
                future.set_exception(
                    Unavailable(
                        f"the playback worker (pid {self.pid}) {self.gone} while this scrub "
                        "was waiting for it; try again: the next scrub starts a new worker"
                    )
                )

    def _take(self, msg: dict[str, Any]) -> None:
        if "stats" in msg:
            self.stats = _checked_stats(msg["stats"])
        rid = msg.get("id")
        if rid is None:
            return
        future = self.pending.get(rid) if type(rid) is int else None
        if future is None or future.done():
            return  # its caller went away (the answer is dropped)
        if "ok" in msg:
            future.set_result(_checked_answer(msg["ok"]))
        elif msg.get("error") == "conflict":
            future.set_exception(Conflict(str(msg.get("message"))))
        else:
            future.set_exception(
                Unavailable(f"the playback worker failed on this scrub: {msg.get('message')}")
            )


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
