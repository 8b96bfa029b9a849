"""Playback: a mission exactly as it was at any simulated time (`app/services/playback.py`)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query

from app.api.convert import mission_read
from app.api.deps import MissionId, PlaybackDep, Viewer
from app.api.schemas import EventRead, MissionStateAt

router = APIRouter(prefix="/missions/{mission_id}", tags=["history"], dependencies=[Viewer])

SimTime = Annotated[
    float, Query(ge=0, le=1e9, allow_inf_nan=False, description="simulated time (s)")
]


@router.get("/state")
async def state_at(mission_id: MissionId, t: SimTime, playback: PlaybackDep) -> MissionStateAt:
    """The map, robots, open auctions, counters, recent auctions and deliveries at time `t`
    (0 ≤ t ≤ the mission's simulated time; live, finished, stalled or interrupted alike)."""
    s = await playback.state_at(mission_id, t)
    return MissionStateAt(
        t=s.t,
        end=s.end,
        mission=mission_read(s.row, s.live),
        state=s.state,
        auctions=s.auctions,
        deliveries=[EventRead.model_validate(d) for d in s.deliveries],
        events=s.events,
    )
