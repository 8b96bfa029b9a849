"""Field missions outlive their server: what is kept to reach them again, and attaching.

A field mission's world and robots run in processes of their own (`field.world_process`), so
a server that stops — SIGTERM or SIGKILL — leaves them mining. What the next server needs to
take the mission back is kept with the database (`FieldLink`): its key space, the world's
endpoint and the mission's authority (so it can speak as mission control, one certificate
generation newer). On start it attaches to every field mission still stored as live whose
world answers, rebuilds its live view from what is stored (events, auctions, actions), and
reads each process life back from past the last event it stored (`field.world_handle`):
every event of the gap is stored once. One whose world does not answer is interrupted, as
before.
"""

from __future__ import annotations

import asyncio
import base64
import logging
from dataclasses import dataclass, field
from typing import Any

from sqlalchemy import func, select, update
from sqlalchemy.orm import Session, selectinload

from app.db.models import Action, Auction, Event, FieldLink, Mission, Pose
from app.live.recorder import Recorder, Stored
from app.services.field_playback import auction_record
from app.services.store import LIVE_STATUSES, Store, stored_counts
from engine import Scenario

log = logging.getLogger("regolith.field_links")

ATTACH_WAIT_S = 15.0
"""How long a starting server waits for a field mission's world to answer."""


def link_fields(mission: Any) -> dict[str, Any]:
    """The `FieldLink` row of a new field mission (`field.control.FieldMission`)."""
    handle = mission.fleet
    return {
        "key_space": handle.mission,
        "endpoint": handle.endpoint,
        "authority": base64.b64encode(handle.authority.secret).decode(),
        "control_gen": handle.authority.control.gen,
        "world_pid": handle.pid,
    }


@dataclass
class Attachment:
    """What is stored of a field mission, to take it back."""

    row: Mission
    link: FieldLink
    control_gen: int
    first_seq: int
    taken: dict[str, int]
    stored: Stored
    auctions: dict[str, dict[str, Any]] = field(default_factory=dict)
    actions: list[dict[str, Any]] = field(default_factory=list)


def _live_links(session: Session) -> list[int]:
    rows = session.execute(
        select(Mission.id)
        .join(FieldLink, FieldLink.mission_id == Mission.id)
        .where(Mission.mode == "field", Mission.status.in_(LIVE_STATUSES))
    )
    return [int(r[0]) for r in rows]


def _next_generation(session: Session, mission_id: int) -> int:
    """Mission control's certificate for this server: newer than every one before."""
    gen = int(
        session.scalar(select(FieldLink.control_gen).where(FieldLink.mission_id == mission_id))
    )
    session.execute(
        update(FieldLink).where(FieldLink.mission_id == mission_id).values(control_gen=gen + 1)
    )
    return gen + 1


def _attachment(session: Session, mission_id: int, gen: int) -> Attachment:
    row = session.get(Mission, mission_id)
    link = session.get(FieldLink, mission_id)
    assert row is not None and link is not None
    last = session.scalar(select(func.max(Event.seq)).where(Event.mission_id == mission_id))
    taken: dict[str, int] = {}
    for table in (Event, Pose):  # (a batch is stored whole: each life's is a prefix)
        for src, top in session.execute(
            select(table.source, func.max(table.rseq))
            .where(table.mission_id == mission_id, table.source.is_not(None))
            .group_by(table.source)
        ):
            taken[str(src)] = max(taken.get(str(src), 0), int(top) + 1)
    stored = stored_counts(session, mission_id)
    stored.events = 0  # the rebuilt log holds only what comes next (numbered on from `last`)
    att = Attachment(row, link, gen, 0 if last is None else int(last) + 1, taken, stored)
    auctions = select(Auction).where(Auction.mission_id == mission_id)
    for a in session.scalars(
        auctions.options(selectinload(Auction.bids), selectinload(Auction.awards))
    ):
        att.auctions[a.auction_id] = auction_record(a)
    att.actions = [
        {"t": x.t, "kind": x.kind, "args": dict(x.args or {})}
        for x in session.scalars(
            select(Action).where(Action.mission_id == mission_id).order_by(Action.seq)
        )
    ]
    session.expunge_all()
    return att


def _attach(att: Attachment) -> Any:
    """The field mission, taken back (on a worker thread: it waits for the world's answer)."""
    from field.control import FieldMission
    from field.trust import Authority
    from field.world_handle import WorldHandle

    row, link = att.row, att.link
    scenario = Scenario.model_validate(row.scenario)
    authority = Authority.restore(link.key_space, base64.b64decode(link.authority), att.control_gen)
    handle = WorldHandle(
        link.key_space,
        link.endpoint,
        authority,
        scenario,
        row.seed,
        row.current_policy,
        taken=att.taken,
        preload=att.auctions,
        wait_s=ATTACH_WAIT_S,
    )
    handle.pid = link.world_pid
    mission = FieldMission(
        scenario,
        row.seed,
        row.policy,
        float(row.speed or 20.0),
        handle=handle,
        first_seq=att.first_seq,
    )
    mission.actions.extend(att.actions)
    return mission


async def reattach(store: Store, runner: Any) -> frozenset[int]:
    """Take back every stored live field mission whose world still answers; their ids."""
    attached: set[int] = set()
    for mission_id in await store.read(_live_links):
        gen = await store.write(_next_generation, mission_id)
        att = await store.read(_attachment, mission_id, gen)
        try:
            mission = await asyncio.to_thread(_attach, att)
        except Exception as exc:  # no world answers, or what is stored cannot be used
            log.warning(
                "field mission %s not attached again: %s",
                mission_id,
                exc,
                extra={"mission_id": mission_id},
            )
            continue
        gap = max(0.0, float(mission.now) - float(att.row.sim_time or 0.0))
        mission.log.emit("control_returned", gap_s=gap, stored_events=att.first_seq)
        with runner.gate:
            runner.add(
                mission_id,
                mission,
                speed=mission.speed,
                paused=mission.paused,  # as its world's clock stands (paused before the stop)
                recorder=Recorder(mission_id, mission, att.stored),
                row=att.row,
            )
        attached.add(mission_id)
        log.warning(
            "field mission %s attached again (%.0f s of mission time since its last record)",
            mission_id,
            gap,
            extra={"mission_id": mission_id},
        )
    return frozenset(attached)
