"""Crash recovery: rebuild an interrupted mission from scenario, seed and recorded actions.

A mission is fully determined by those, so replaying the actions at their simulation times
reproduces the stored event log exactly; it is checked event by event, and a mission whose
replay differs is refused rather than continued on a different history.
"""

from __future__ import annotations

import asyncio
import json
from time import perf_counter
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.db.models import Event
from app.db.models import Mission as MissionRow
from app.live.gate import Gate
from app.live.mission import LiveMission
from app.live.recorder import Recorder
from app.live.runner import MissionRunner
from app.services.errors import Conflict
from app.services.store import Store, stored_counts
from engine import Mission, parse_scenario
from engine.mission import PLANNERS

_PAGE = 5000
_SLICE_S = 0.005


async def _advance_to(gate: Gate, m: Mission, t: float) -> None:
    """Advance in bounded slices under the gate, so live missions keep running meanwhile."""
    chunk = 1.0
    while m.now < t and not m.done:
        t0 = perf_counter()
        with gate:
            m.advance(min(t, m.now + chunk))
        took = perf_counter() - t0
        chunk = chunk * 2 if took < _SLICE_S / 4 else max(chunk / 2, 1e-3)
        await asyncio.sleep(0)


def _events_page(session: Session, mission_id: int, after: int) -> list[tuple[Any, ...]]:
    rows = session.execute(
        select(Event.seq, Event.t, Event.kind, Event.data)
        .where(Event.mission_id == mission_id, Event.seq > after)
        .order_by(Event.seq)
        .limit(_PAGE)
    )
    return [tuple(r) for r in rows]


async def _check(store: Store, mission_id: int, m: Mission, stored: int) -> None:
    log = m.events
    if len(log) < stored:
        raise Conflict(
            f"mission {mission_id}: replay produced {len(log)} events but {stored} are stored; "
            "refusing to continue on a different history"
        )
    after = -1
    while True:
        page = await store.read(_events_page, mission_id, after)
        if not page:
            return
        for seq, t, kind, data in page:
            ev = log[seq]
            same = ev.t == t and ev.kind == kind and json.loads(json.dumps(ev.data)) == data
            if not same:
                raise Conflict(
                    f"mission {mission_id}: replay differs from the stored log at event {seq} "
                    f"({kind} at t={t}); refusing to continue on a different history"
                )
        after = page[-1][0]


def _last_event_t(session: Session, mission_id: int) -> float | None:
    return session.scalar(select(func.max(Event.t)).where(Event.mission_id == mission_id))


async def revive(runner: MissionRunner, store: Store, row: MissionRow) -> LiveMission:
    """Replay `row` to its last stored simulation time and hand it to the runner (paused).

    That time is the mission's `sim_time`, or its last stored event's if later: a batch's
    events are written in chunks before the transaction that moves `sim_time` (and stores its
    auctions), so a crash between them leaves events past `sim_time`. They are the mission's
    history all the same: replayed, checked, and continued from.
    """
    gate = runner.gate
    with gate:
        planner = row.planner if row.planner in PLANNERS else "ompl"
        m = Mission(parse_scenario(row.scenario), row.seed, row.policy, planner=planner)  # type: ignore[arg-type]
    try:
        for action in sorted((a for a in row.actions if a.replay), key=lambda a: a.seq):
            await _advance_to(gate, m, action.t)
            with gate:
                m.apply({"t": action.t, "kind": action.kind, "args": action.args})
        last_event_t = await store.read(_last_event_t, row.id)
        await _advance_to(gate, m, max(row.sim_time, last_event_t or 0.0))
        stored = await store.read(stored_counts, row.id)
        await _check(store, row.id, m, stored.events)
    except BaseException:
        m.close()
        raise
    with gate:
        return runner.add(
            row.id, m, speed=row.speed, paused=True, recorder=Recorder(row.id, m, stored), row=row
        )
