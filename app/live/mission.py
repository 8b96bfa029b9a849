"""One live mission as the runner holds it: the engine, its hub and recorder, its pacing
(speed, anchor, adaptive chunk) and what is waiting to be streamed and written."""

from __future__ import annotations

import asyncio
import math
from dataclasses import dataclass, field
from time import perf_counter
from typing import Any

from app.live.hub import Hub
from app.live.recorder import Recorder
from engine import Event, MissionInterface

#: Events per batch; a mission this far ahead of a batch still being written waits for it,
#: so "max" speed never outruns the database and an operator waits behind little.
BATCH_EVENTS = 500


@dataclass(eq=False)
class LiveMission:
    """A mission being stepped, with its pacing and streaming state."""

    id: int
    mission: MissionInterface
    hub: Hub
    recorder: Recorder
    speed: float | None  # None: as fast as possible
    paused: bool
    chunk: float = 0.5
    anchor_wall: float = 0.0
    anchor_sim: float = 0.0
    finishing: bool = False
    crashed: str | None = None
    last_flush: float = 0.0
    last_frame_t: float = -1.0
    outbox: list[Event] = field(default_factory=list)
    dirty_auctions: set[str] = field(default_factory=set)
    row: Any = None  # the stored record's static fields (detached ORM object)
    final_status: str | None = None
    final_task: asyncio.Task[None] | None = None
    writing: asyncio.Task[None] | None = None  # the latest batch write (they are chained)

    @property
    def runnable(self) -> bool:
        """Stepping it now is allowed (not paused or ending, and the store keeps up)."""
        if self.paused or self.finishing or self.crashed or self.mission.done:
            return False
        return self.write_idle or self.recorder.pending < BATCH_EVENTS

    @property
    def write_idle(self) -> bool:
        return self.writing is None or self.writing.done()

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
