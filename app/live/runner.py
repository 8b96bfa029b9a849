"""The live runner: the registry of live missions and everything the event loop does for them.

Missions advance on the stepping thread (`app/live/stepper.py`); everything else that touches
an engine (commands, snapshots, frames, fan-out, batching) happens on the event loop under
the same gate (`app/live/gate.py`), so no two threads ever touch the engine at once. Every
`tick_s` the loop streams what the engine produced and writes it in batches; a separate task
samples frames at a steady rate.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from time import perf_counter
from typing import Any

from app.db.models import utcnow
from app.live.gate import Gate
from app.live.gc_pause import GcPause
from app.live.hub import Hub
from app.live.mission import BATCH_EVENTS, LiveMission
from app.live.modes import dropped_of, is_field
from app.live.recorder import Recorder
from app.live.records import describe, failed_record
from app.live.stepper import Stepper
from app.live.streaming import note_auction, note_event, publish_pending
from app.live.writes import BatchWriter, MissionWrites, safe_now
from app.settings import Settings
from engine import MissionInterface

log = logging.getLogger("regolith.runner")

TICK_S = 0.01


class MissionRunner:
    """Owns the live missions, their hubs, the stepping thread and the loop-side tasks.

    The services change a live mission only through its methods (`add`, `pause`, `resume`,
    `set_speed`, `finish`, `snapshot`, ...), holding the gate."""

    def __init__(self, settings: Settings, store: BatchWriter) -> None:
        self.settings = settings
        self.writes = MissionWrites(store)
        self.gate = Gate()
        self.live: dict[int, LiveMission] = {}
        self.hubs: dict[int, Hub] = {}
        self.stepper = Stepper(
            lambda: list(self.live.values()),
            self.gate,
            settings.slice_ms / 1000,
            settings.max_lag_s,
        )
        self.gc_pause = GcPause()
        self._tasks: list[asyncio.Task[None]] = []
        # what field missions that ended had dropped from their bus, by reason (`/metrics`)
        self.field_dropped: Counter[str] = Counter()

    # -- lifecycle ---------------------------------------------------------------------

    async def start(self) -> None:
        self.gc_pause.start()
        self.stepper.start()
        self._tasks = [
            asyncio.create_task(self._tick_forever(), name="regolith-tick"),
            asyncio.create_task(self._frames_forever(), name="regolith-frames"),
        ]

    async def aclose(self) -> None:
        """Stop stepping, write everything out and mark unfinished missions interrupted (not
        field missions: their processes go on, `app/services/field_links.py`)."""
        await asyncio.to_thread(self.stepper.stop)
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        for lm in list(self.live.values()):
            if lm.finishing:
                continue
            with self.gate:
                if is_field(lm.mission):  # its robots mine on: the next server takes it back
                    self.writes.write(lm, {"sim_time": safe_now(lm)})
                    continue
                snap = self._safe_snap(lm, "interrupted")
                self.writes.write(lm, {"status": "interrupted", "final_state": snap})
        await self.writes.drain()
        with self.gate:
            for lm in self.live.values():
                if is_field(lm.mission) and not lm.finishing:
                    lm.mission.detach()
                else:
                    lm.mission.close()
        self.live.clear()
        self.gc_pause.stop()

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
        mission: MissionInterface,
        *,
        speed: float | None,
        paused: bool,
        recorder: Recorder | None = None,
        row: Any = None,
    ) -> LiveMission:
        """Start stepping `mission` (already stored under `mission_id` as `row`; caller holds
        the gate)."""
        lm = LiveMission(
            id=mission_id,
            mission=mission,
            hub=self.hub(mission_id),
            recorder=recorder or Recorder(mission_id, mission),
            speed=speed,
            paused=paused,
            last_flush=perf_counter(),
            row=row,
        )
        lm.reanchor()
        mission.subscribe(lambda ev: note_event(lm, ev))
        mission.watch_auctions(lambda aid: note_auction(lm, aid))
        self.live[mission_id] = lm
        log.info(
            "mission %s live at t=%.1f (%s)",
            mission_id,
            mission.now,
            "paused" if paused else f"speed {'max' if speed is None else speed}",
            extra={"mission_id": mission_id},
        )
        self.stepper.wake()
        return lm

    # -- what the services ask of a live mission (callers hold the gate) ------------------

    def pause(self, lm: LiveMission) -> float:
        """Stop stepping `lm` and tell its viewers; the simulation time it paused at. A field
        mission's agents run on their own: its clock is paused (every agent's with it)."""
        if is_field(lm.mission):
            lm.mission.pause()
        lm.paused = True
        self._publish_frame(lm, ordered=True)  # what it was at the pause, before "paused"
        lm.hub.publish(lm.status_message())
        return float(lm.mission.now)

    def resume(self, lm: LiveMission) -> float:
        """Step `lm` again, paced from now, and tell its viewers; the simulation time."""
        if is_field(lm.mission):
            lm.mission.resume()
        lm.paused = False
        lm.reanchor()
        lm.hub.publish(lm.status_message())
        self.stepper.wake()
        return float(lm.mission.now)

    def set_speed(self, lm: LiveMission, speed: float | None) -> float:
        """Step `lm` at `speed` (None: as fast as possible), paced from now; the time. (A
        field mission: its clock is re-paced, every agent's with it; never None, checked.)"""
        if is_field(lm.mission) and speed is not None:
            lm.mission.set_speed(speed)
        lm.speed = speed
        lm.reanchor()
        lm.hub.publish(lm.status_message())
        self.stepper.wake()
        return float(lm.mission.now)

    def note_row(self, lm: LiveMission, row: Any) -> None:
        """The stored record's static fields, for rendering `lm` (kept if already known)."""
        lm.row = lm.row or row

    def snapshot(self, lm: LiveMission) -> tuple[dict[str, Any], dict[str, Any]]:
        """What a joining viewer starts from: the pending stream flushed, then the frame
        stream brought up to date (its full frame, with `seq`) and the mission's snapshot
        whose robots carry the stream's rounded poses, so the next delta applies exactly."""
        self.publish_pending(lm)
        m = lm.mission
        full = self.hub(lm.id).sync(m.frame())
        lm.last_frame_t = float(m.now)
        snap = m.snapshot()
        streamed = {r["name"]: r for r in full["robots"]}
        snap["robots"] = [{**r, **streamed.get(r["name"], {})} for r in snap["robots"]]
        return full, snap

    @contextmanager
    def operator_request(self) -> Iterator[None]:
        """While an operator's request runs, the stepping thread yields the CPU to it."""
        self.stepper.operators += 1
        try:
            yield
        finally:
            self.stepper.operators -= 1

    def running_count(self) -> int:
        return sum(1 for lm in self.live.values() if not lm.finishing)

    def publish_pending(self, lm: LiveMission) -> None:
        """Stream what `lm` produced since the last call (under the gate)."""
        publish_pending(lm)

    async def flush(self, lm: LiveMission) -> None:
        """Write everything new for `lm` now (reads after this see it)."""
        with self.gate:
            task = self.writes.write(lm)
        await task

    def finish(
        self, lm: LiveMission, status: str, error: str | None = None
    ) -> asyncio.Task[None] | None:
        """End a mission (naturally, stopped or failed; under the gate): stream the end, write
        the final record (last batch, metrics, final state), then drop the engine."""
        if lm.finishing:
            return lm.final_task
        lm.finishing = True
        lm.final_status = status
        level = logging.ERROR if error is not None else logging.INFO
        log.log(
            level,
            "mission %s ended: %s at t=%.1f%s",
            lm.id,
            status,
            lm.mission.now,
            f" ({error})" if error else "",
            extra={"mission_id": lm.id},
        )
        try:
            self.publish_pending(lm)
            lm.hub.publish_frame({**lm.mission.frame(), "status": status}, last=True)
        except Exception:  # a failed engine may not produce a frame; the status still goes
            log.exception("final frame of mission %s failed", lm.id, extra={"mission_id": lm.id})
        lm.hub.publish(lm.status_message())
        changes: dict[str, Any] = {"status": status, "ended_at": utcnow()}
        if error is None:
            try:
                changes["metrics"] = lm.mission.metrics()
            except Exception as exc:
                log.exception("metrics of mission %s failed", lm.id, extra={"mission_id": lm.id})
                changes = failed_record(changes, f"metrics not computed: {describe(exc)}")
            changes["final_state"] = self._safe_snap(lm, changes["status"])
        else:
            changes["error"] = error
        written = self.writes.write(lm, changes)

        async def close() -> None:
            try:
                await written
            finally:
                with self.gate:
                    self._close_engine(lm)
                self.live.pop(lm.id, None)
                self.forget_hub(lm.id)

        lm.final_task = self.writes.spawn(close())
        return lm.final_task

    def _close_engine(self, lm: LiveMission) -> None:
        """Stop a mission's engine (a field mission: its agents); never raises."""
        try:
            self.field_dropped.update(dropped_of(lm.mission))
            lm.mission.close()
        except Exception:
            log.exception("closing mission %s failed", lm.id, extra={"mission_id": lm.id})

    def quarantine(self, lm: LiveMission, exc: BaseException) -> None:
        """One mission's data broke the service's handling of it (under the gate): that
        mission alone ends as failed, with the reason; every other one goes on."""
        reason = f"the service could not handle this mission's data: {describe(exc)}"
        log.error("mission %s: %s", lm.id, reason, exc_info=exc, extra={"mission_id": lm.id})
        lm.crashed = lm.crashed or reason
        try:
            self.finish(lm, "failed", error=lm.crashed)
        except Exception:  # the last resort: the record as it is, the engine stopped
            log.exception("ending mission %s failed", lm.id, extra={"mission_id": lm.id})
            lm.finishing, lm.final_status = True, "failed"
            self._close_engine(lm)
            self.live.pop(lm.id, None)

    @staticmethod
    def _safe_snap(lm: LiveMission, status: str) -> dict[str, Any] | None:
        """The stored last state, carrying the record's status (the engine's snapshot says
        "running" for a mission the service stopped or interrupted)."""
        try:
            snap: dict[str, Any] = {**lm.mission.snapshot(), "status": status}
            return snap
        except Exception:  # a broken engine state must not lose the rest of the record
            log.exception("snapshot of mission %s failed", lm.id, extra={"mission_id": lm.id})
            return None

    # -- loop-side tasks ---------------------------------------------------------------

    def _maintain(self) -> None:
        """Stream what the engine produced, end finished missions, flush when due."""
        now = perf_counter()
        with self.gate:
            for lm in list(self.live.values()):
                if lm.finishing:
                    continue
                try:
                    self._maintain_one(lm, now)
                except Exception as exc:
                    self.quarantine(lm, exc)

    def _maintain_one(self, lm: LiveMission, now: float) -> None:
        self.publish_pending(lm)
        if lm.crashed is not None:
            self.finish(lm, "failed", error=lm.crashed)
        elif lm.mission.done:
            self.finish(lm, str(lm.mission.status))
        elif lm.write_idle and (
            now - lm.last_flush >= self.settings.flush_interval_s
            or lm.recorder.pending >= BATCH_EVENTS
        ):
            self.writes.write(lm)
            self.stepper.wake()

    def _publish_frame(self, lm: LiveMission, ordered: bool = False) -> None:
        """`lm`'s frame to its viewers if its time moved since the last (`Hub.publish_frame`);
        a mission whose engine fails to give one is quarantined."""
        try:
            if lm.finishing or not lm.hub.viewers:
                return
            if lm.mission.now != lm.last_frame_t or ordered:
                lm.last_frame_t = float(lm.mission.now)
                lm.hub.publish_frame(lm.mission.frame(), ordered=ordered)
        except Exception as exc:
            self.quarantine(lm, exc)

    async def _tick_forever(self) -> None:
        while True:
            await asyncio.sleep(TICK_S)
            self._maintain()
            self.gc_pause.tick(busy=any(lm.runnable for lm in self.live.values()))

    async def _frames_forever(self) -> None:
        period = 1.0 / self.settings.frame_hz
        next_at = perf_counter()
        while True:
            next_at += period
            delay = next_at - perf_counter()
            if delay < 0:  # fell behind: skip, never burst
                next_at = perf_counter()
                delay = 0
            await asyncio.sleep(delay)
            with self.gate:
                for lm in list(self.live.values()):
                    self._publish_frame(lm)
