"""What an export reads: a stored mission's events, operator actions and, for a simulated
mission, robot poses rebuilt by replay; each a stream in simulated-time order.

Nothing is read whole: events come in pages, and poses from one engine replaying the mission
tick by tick, so an export's memory does not grow with the mission's length.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Any, TypeVar

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.db.models import Action, Event
from app.db.models import Mission as MissionRow
from engine import Mission, parse_scenario
from engine.mission import PLANNERS

T = TypeVar("T")
#: `read(fn, *args)`: `fn(session, *args)` on the calling thread, with a fresh session.
Reader = Callable[..., Any]
#: Simulated seconds between two pose samples of a simulated mission.
POSE_STEP_S = 5.0
PAGE = 2000

# Merge order at one simulated time: an operator action, then the events it caused (in log
# order), then the poses showing the result.
ACTION, EVENT, POSE = 0, 1, 2


@dataclass(frozen=True)
class StoredMission:
    """The stored fields an export needs, read once (a live mission keeps changing)."""

    id: int
    mode: str
    status: str
    scenario_name: str
    scenario: dict[str, Any]
    seed: int
    policy: str
    planner: str
    world_map: dict[str, Any] | None
    sim_time: float
    last_seq: int
    actions: list[dict[str, Any]]


def load_now(session: Session, mission_id: int) -> StoredMission | None:
    """The mission as stored now, or None if there is no such mission."""
    row = session.get(MissionRow, mission_id)
    if row is None:
        return None
    last = session.scalar(select(func.max(Event.seq)).where(Event.mission_id == mission_id))
    actions = session.scalars(
        select(Action).where(Action.mission_id == mission_id).order_by(Action.seq)
    ).all()
    return StoredMission(
        id=row.id,
        mode=row.mode,
        status=row.status,
        scenario_name=row.scenario_name,
        scenario=row.scenario,
        seed=row.seed,
        policy=row.policy,
        planner=row.planner,
        world_map=row.world_map,
        sim_time=row.sim_time,
        last_seq=-1 if last is None else int(last),
        actions=[
            {"seq": a.seq, "t": a.t, "kind": a.kind, "args": a.args, "replay": a.replay}
            for a in actions
        ],
    )


def _page(session: Session, mission_id: int, after: int, last: int) -> list[tuple[Any, ...]]:
    rows = session.execute(
        select(Event.seq, Event.t, Event.kind, Event.data)
        .where(Event.mission_id == mission_id, Event.seq > after, Event.seq <= last)
        .order_by(Event.seq)
        .limit(PAGE)
    )
    return [tuple(r) for r in rows]


def events(read: Reader, m: StoredMission) -> Iterator[tuple[int, float, str, dict[str, Any]]]:
    """The stored events up to those there when the export began, a page at a time."""
    after = -1
    while after < m.last_seq:
        page = read(_page, m.id, after, m.last_seq)
        if not page:
            return
        for seq, t, kind, data in page:
            yield int(seq), float(t), str(kind), data
        after = int(page[-1][0])


Gate = Callable[[], AbstractContextManager[Any]]


def replay_robots(
    m: StoredMission, gate: Gate = contextlib.nullcontext, step: float = POSE_STEP_S
) -> Iterator[tuple[float, list[dict[str, Any]], dict[str, int]]]:
    """A simulated mission's robots and counters every `step` simulated seconds up to its
    stored time, rebuilt by replaying its scenario, seed and replayable actions (the engine
    is deterministic: docs/engine-api.md). `gate` guards each engine step (the server's
    engine gate, so live missions keep stepping meanwhile)."""
    planner = m.planner if m.planner in PLANNERS else "ompl"
    with gate():
        engine = Mission(parse_scenario(m.scenario), m.seed, m.policy, planner=planner)  # type: ignore[arg-type]
    try:
        todo = [a for a in m.actions if a["replay"]]
        t = 0.0
        while True:
            with gate():
                while todo and float(todo[0]["t"]) <= t:
                    a = todo.pop(0)
                    engine.advance(float(a["t"]))
                    engine.apply({"t": a["t"], "kind": a["kind"], "args": a["args"]})
                engine.advance(t)
                robots, counters = engine.robot_list(), engine.counters()
            yield t, robots, counters
            if t >= m.sim_time or engine.done:
                return
            t = min(t + step, m.sim_time)
            time.sleep(0)  # let a stepping thread or a request in between two ticks
    finally:
        with gate():
            engine.close()
