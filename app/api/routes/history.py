"""A mission's stored history: auctions (with bids and awards) and the engine's event log."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query

from app.api.convert import auction_read
from app.api.deps import MissionId, MissionsDep, Viewer
from app.api.schemas import AuctionPage, EventPage, EventRead
from app.services import queries

router = APIRouter(prefix="/missions/{mission_id}", tags=["history"], dependencies=[Viewer])

Short = Annotated[str, Query(min_length=1, max_length=80)]
Time = Annotated[float, Query(ge=0, le=1e9, allow_inf_nan=False)]


@router.get("/auctions")
async def list_auctions(
    mission_id: MissionId,
    missions: MissionsDep,
    kind: Short | None = None,
    status: Short | None = None,
    robot: Annotated[
        str | None, Query(max_length=80, description="auctioneer, bidder or winner")
    ] = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 100,
    offset: Annotated[int, Query(ge=0, le=10_000_000)] = 0,
) -> AuctionPage:
    """Auctions in opening order, each with its bids, awards, declines and open/close times."""
    await missions.fresh(mission_id)
    page = await missions.store.read(
        queries.list_auctions, mission_id, kind, status, robot, limit, offset
    )
    return AuctionPage(
        items=[auction_read(a) for a in page.items], total=page.total, limit=limit, offset=offset
    )


@router.get("/events")
async def list_events(
    mission_id: MissionId,
    missions: MissionsDep,
    kind: Annotated[list[str], Query(max_length=32)] = [],  # noqa: B006 - FastAPI copies it
    t_min: Time | None = None,
    t_max: Time | None = None,
    after: Annotated[int, Query(ge=-1, le=2**31)] = -1,
    limit: Annotated[int, Query(ge=1, le=1000)] = 200,
) -> EventPage:
    """Events with `seq > after`, optionally only some kinds and a time window."""
    await missions.fresh(mission_id)
    page = await missions.store.read(
        queries.list_events, mission_id, kind, t_min, t_max, after, limit
    )
    items = [EventRead.model_validate(e) for e in page.items]
    next_after = items[-1].seq if len(items) == limit else None
    return EventPage(items=items, total=page.total, limit=limit, next_after=next_after)
