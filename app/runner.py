"""The live runner: every engine call of every live mission happens on the event loop thread.

The engine is synchronous and OMPL's random generator is process-global, so missions are
never stepped concurrently. One task advances all runnable missions in bounded slices (a
few milliseconds of wall time, shared between missions), then yields, so HTTP requests and
WebSocket viewers stay responsive even at "max" speed. A second task samples frames at a
steady rate. Event batches go to the store every `flush_interval_s`, never per event.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections.abc import Coroutine
from dataclasses import dataclass, field
from time import perf_counter
from typing import Any

from app.db.models import utcnow
from app.live import Hub
from app.services.recorder import Recorder
from app.services.store import Store
from app.settings import Settings
from engine import Mission

log = logging.getLogger("regolith.runner")

#: Event kinds not forwarded to viewers: raw bus traffic (bids arrive as `auction` updates).
QUIET_KINDS = frozenset({"message", "bid"})
_MIN_CHUNK, _MAX_CHUNK = 1e-3, 600.0


@dataclass(eq=False)
class LiveMission:
    """A mission the runner is stepping, with its pacing and streaming state."""

    id: int
    mission: Mission
    hub: Hub
    recorder: Recorder
    speed: float | None  # None: as fast as possible
    paused: bool
    chunk: float = 0.5
    anchor_wall: float = 0.0
    anchor_sim: float = 0.0
    finishing: bool = False
    last_flush: float = 0.0
    last_frame_t: float = -1.0
    dirty_auctions: set[str] = field(default_factory=set)
    row: Any = None  # the stored record's static fields (detached ORM object)
    final_status: str | None = None
    final_task: asyncio.Task[None] | None = None

    @property
    def runnable(self) -> bool:
        return not (self.paused or self.finishing or self.mission.done)

    @property
    def status(self) -> str:
        if self.final_status is not None:
            return self.final_status
        if self.mission.done:
            return str(self.mission.status)
        return "paused" if self.paused else "running"

    def reanchor(self) -> None:
        """Start pacing afresh from now (after resume, speed change or falling behind)."""
        self.anchor_wall = perf_counter()
        self.anchor_sim = float(self.mission.now)

    def target(self, wall: float, max_lag_s: float) -> float:
        """Simulation time the mission should have reached at `wall`."""
        if self.speed is None:
            return math.inf
        want = self.anchor_sim + self.speed * (wall - self.anchor_wall)
        if want - self.mission.now > self.speed * max_lag_s:  # too far behind: drop the debt
            self.anchor_wall, self.anchor_sim = wall, float(self.mission.now)
            want = self.anchor_sim
        return want

    def status_message(self) -> dict[str, Any]:
        return {
            "type": "status",
            "status": self.status,
            "policy": self.mission.policy,
            "speed": "max" if self.speed is None else self.speed,
        }


class MissionRunner:
    """Owns the live missions, their hubs and the two pacing tasks."""

    def __init__(self, settings: Settings, store: Store) -> None:
        self.settings = settings
        self.store = store
        self.live: dict[int, LiveMission] = {}
        self.hubs: dict[int, Hub] = {}
        self.policies: dict[int, str] = {}
        self._wake = asyncio.Event()
        self._tasks: list[asyncio.Task[None]] = []
        self._pending: set[asyncio.Task[Any]] = set()

    # -- lifecycle ---------------------------------------------------------------------

    async def start(self) -> None:
        self._tasks = [
            asyncio.create_task(self._step_forever(), name="regolith-step"),
            asyncio.create_task(self._frames_forever(), name="regolith-frames"),
        ]

    async def aclose(self) -> None:
        """Stop stepping, write everything out and mark unfinished missions interrupted."""
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        await self.drain()
        for lm in list(self.live.values()):
            if lm.finishing:
                continue
            changes: dict[str, Any] = {"status": "interrupted", "final_state": self._safe_snap(lm)}
            await self.store.write_batch(lm.recorder.collect(), changes)
            lm.mission.close()
        await self.drain()
        self.live.clear()

    async def drain(self) -> None:
        while self._pending:
            await asyncio.gather(*list(self._pending), return_exceptions=True)

    def _spawn(self, coro: Coroutine[Any, Any, None]) -> asyncio.Task[None]:
        task = asyncio.create_task(coro)
        self._pending.add(task)
        task.add_done_callback(self._done)
        return task

    def _done(self, task: asyncio.Task[Any]) -> None:
        self._pending.discard(task)
        if not task.cancelled() and task.exception() is not None:
            log.error("background write failed", exc_info=task.exception())

    # -- missions ----------------------------------------------------------------------

    def hub(self, mission_id: int) -> Hub:
        hub = self.hubs.get(mission_id)
        if hub is None:
            hub = self.hubs[mission_id] = Hub(self.settings.viewer_queue)
        return hub

    def forget_hub(self, mission_id: int) -> None:
        hub = self.hubs.get(mission_id)
        if hub is not None and not hub.viewers and mission_id not in self.live:
            del self.hubs[mission_id]

    def add(
        self,
        mission_id: int,
        mission: Mission,
        *,
        speed: float | None,
        paused: bool,
        recorder: Recorder | None = None,
    ) -> LiveMission:
        """Start stepping `mission` (already stored under `mission_id`)."""
        lm = LiveMission(
            id=mission_id,
            mission=mission,
            hub=self.hub(mission_id),
            recorder=recorder or Recorder(mission_id, mission),
            speed=speed,
            paused=paused,
            last_flush=perf_counter(),
        )
        lm.reanchor()
        mission.subscribe(lambda ev: self._on_event(lm, ev))
        self.live[mission_id] = lm
        self.wake()
        return lm

    def wake(self) -> None:
        self._wake.set()

    def running_count(self) -> int:
        return sum(1 for lm in self.live.values() if not lm.finishing)

    def _on_event(self, lm: LiveMission, ev: Any) -> None:
        """Engine callback (inside `advance`): note auction changes, stream notable events."""
        aid = ev.data.get("auction_id")
        if aid is not None and lm.hub.viewers:
            lm.dirty_auctions.add(aid)
        if ev.kind not in QUIET_KINDS and lm.hub.viewers:
            lm.hub.publish({"type": "event", "event": ev.to_dict()})

    def publish_auctions(self, lm: LiveMission) -> None:
        """One `auction` message per auction that changed since the last call."""
        if not lm.dirty_auctions:
            return
        dirty, lm.dirty_auctions = lm.dirty_auctions, set()
        if not lm.hub.viewers:
            return
        by_id = {rec.id: rec for rec in lm.mission.auctions if rec.id in dirty}
        for aid in sorted(dirty):
            if aid in by_id:
                lm.hub.publish({"type": "auction", "auction": by_id[aid].to_dict()})

    async def flush(self, lm: LiveMission, changes: dict[str, Any] | None = None) -> None:
        """Write everything new for `lm` now (reads after this see it)."""
        lm.last_flush = perf_counter()
        await self.store.write_batch(lm.recorder.collect(), changes)

    def finish(self, lm: LiveMission, status: str) -> asyncio.Task[None] | None:
        """End a mission (naturally or stopped): final batch, metrics, state; then drop it."""
        if lm.finishing:
            return lm.final_task
        lm.finishing = True
        lm.final_status = status
        self._publish_final(lm, status)
        lm.final_task = self._spawn(self._finish(lm, status))
        return lm.final_task

    def _publish_final(self, lm: LiveMission, status: str) -> None:
        self.publish_auctions(lm)
        try:
            lm.hub.publish_frame({**lm.mission.frame(), "status": status}, last=True)
        except Exception:  # a failed engine may not produce a frame; the status still goes
            log.exception("final frame of mission %s failed", lm.id)
        lm.hub.publish(lm.status_message())

    async def _finish(self, lm: LiveMission, status: str) -> None:
        m = lm.mission
        changes = {
            "status": status,
            "ended_at": utcnow(),
            "metrics": m.metrics(),
            "final_state": self._safe_snap(lm),
        }
        batch = lm.recorder.collect()
        try:
            await self.store.write_batch(batch, changes)
        finally:
            m.close()
            self.live.pop(lm.id, None)
            self.forget_hub(lm.id)

    @staticmethod
    def _safe_snap(lm: LiveMission) -> dict[str, Any] | None:
        try:
            snap: dict[str, Any] = lm.mission.snapshot()
            return snap
        except Exception:  # a broken engine state must not lose the rest of the record
            log.exception("snapshot of mission %s failed", lm.id)
            return None

    # -- pacing ------------------------------------------------------------------------

    def _step(self, lm: LiveMission, wall: float, budget: float) -> bool:
        """Advance `lm` towards its target for at most `budget` s; True if still behind."""
        m = lm.mission
        target = lm.target(wall, self.settings.max_lag_s)
        end = perf_counter() + budget
        while m.now < target and not m.done:
            t0 = perf_counter()
            m.advance(min(target, m.now + lm.chunk))
            took = perf_counter() - t0
            if took > budget / 4:
                lm.chunk = max(lm.chunk / 2, _MIN_CHUNK)
            elif took < budget / 16:
                lm.chunk = min(lm.chunk * 2, _MAX_CHUNK)
            if t0 + took >= end:
                break
        return m.now < target and not m.done

    def _maintain(self) -> None:
        """After a slice: stream auction changes, end finished missions, flush when due."""
        now = perf_counter()
        for lm in list(self.live.values()):
            if lm.finishing:
                continue
            self.publish_auctions(lm)
            if lm.mission.done:
                self.finish(lm, str(lm.mission.status))
            elif now - lm.last_flush >= self.settings.flush_interval_s:
                lm.last_flush = now
                self._spawn(self.store.write_batch(lm.recorder.collect()))

    async def _step_forever(self) -> None:
        budget = self.settings.slice_ms / 1000
        while True:
            active = [lm for lm in self.live.values() if lm.runnable]
            if not active:
                self._wake.clear()
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._wake.wait(), self.settings.flush_interval_s)
                self._maintain()
                continue
            share = max(budget / len(active), 1e-3)
            behind = False
            for lm in active:
                try:
                    behind |= self._step(lm, perf_counter(), share)
                except Exception as exc:  # an engine bug ends that mission, not the server
                    log.exception("mission %s failed while stepping", lm.id)
                    self._fail(lm, exc)
            self._maintain()
            await asyncio.sleep(0 if behind else 0.01)

    def _fail(self, lm: LiveMission, exc: Exception) -> None:
        lm.finishing = True
        lm.final_status = "failed"
        self._publish_final(lm, "failed")
        changes = {
            "status": "failed",
            "ended_at": utcnow(),
            "error": f"{type(exc).__name__}: {exc}",
        }

        async def _write() -> None:
            try:
                await self.store.write_batch(lm.recorder.collect(), changes)
            finally:
                lm.mission.close()
                self.live.pop(lm.id, None)

        lm.final_task = self._spawn(_write())

    async def _frames_forever(self) -> None:
        period = 1.0 / self.settings.frame_hz
        next_at = perf_counter()
        while True:
            next_at += period
            delay = next_at - perf_counter()
            if delay < 0:  # fell behind (a long engine slice): skip, never burst
                next_at = perf_counter()
                delay = 0
            await asyncio.sleep(delay)
            for lm in list(self.live.values()):
                if lm.finishing or not lm.hub.viewers or lm.mission.now == lm.last_frame_t:
                    continue
                lm.last_frame_t = float(lm.mission.now)
                lm.hub.publish_frame(lm.mission.frame())
