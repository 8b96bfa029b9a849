"""Missions: create, list, read, and the lifecycle controls."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, status

from app.api.convert import mission_detail, mission_read
from app.api.deps import MissionId, MissionsDep, Operator, Viewer
from app.api.schemas import (
    ActionRead,
    MissionCreate,
    MissionDetail,
    MissionMode,
    MissionPage,
    MissionRead,
    MissionStatus,
    PolicyFilter,
    PolicyUpdate,
    SpeedUpdate,
)

router = APIRouter(prefix="/missions", tags=["missions"])


@router.post("", status_code=status.HTTP_201_CREATED, dependencies=[Operator])
async def create_mission(body: MissionCreate, missions: MissionsDep) -> MissionDetail:
    """Start a live mission (paused if `paused` or `speed` is 0)."""
    row, live = await missions.create(
        policy=body.policy,
        seed=body.seed,
        speed=body.speed,
        paused=body.paused,
        scenario=body.scenario,
        planner=body.planner,
        field=body.field,
    )
    return mission_detail(row, live, actions=[])


@router.get("", dependencies=[Viewer])
async def list_missions(
    missions: MissionsDep,
    status: MissionStatus | None = None,
    policy: Annotated[PolicyFilter | None, Query()] = None,  # type: ignore[valid-type]
    mode: MissionMode | None = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    offset: Annotated[int, Query(ge=0, le=10_000_000)] = 0,
) -> MissionPage:
    """Newest first; filter by status, (current) policy and mode ("simulated" or "field")."""
    page, live = await missions.page(status, policy, mode, limit, offset)
    items = [mission_read(r, live.get(r.id)) for r in page.items]
    return MissionPage(items=items, total=page.total, limit=limit, offset=offset)


@router.get("/{mission_id}", dependencies=[Viewer])
async def get_mission(mission_id: MissionId, missions: MissionsDep) -> MissionDetail:
    """One mission with live (running) or final metrics in the `regolith run --json` shape."""
    row, live = await missions.detail(mission_id, metrics=True)
    return mission_detail(row, live)


@router.get("/{mission_id}/actions", dependencies=[Viewer])
async def list_actions(mission_id: MissionId, missions: MissionsDep) -> list[ActionRead]:
    """Operator actions in order, with the simulation time each took effect."""
    row, _ = await missions.detail(mission_id)
    return [ActionRead.model_validate(a) for a in row.actions]


async def _current(missions: MissionsDep, mission_id: int) -> MissionRead:
    row, live = await missions.current(mission_id)
    return mission_read(row, live)


@router.post("/{mission_id}/pause", dependencies=[Operator])
async def pause(mission_id: MissionId, missions: MissionsDep) -> MissionRead:
    await missions.pause(mission_id)
    return await _current(missions, mission_id)


@router.post("/{mission_id}/resume", dependencies=[Operator])
async def resume(mission_id: MissionId, missions: MissionsDep) -> MissionRead:
    """Resume a paused mission, or rebuild an interrupted one by replay and continue it."""
    await missions.resume(mission_id)
    return await _current(missions, mission_id)


@router.post("/{mission_id}/stop", dependencies=[Operator])
async def stop(mission_id: MissionId, missions: MissionsDep) -> MissionRead:
    """End the mission now; its record (metrics, final state) is written before answering."""
    await missions.stop(mission_id)
    return await _current(missions, mission_id)


@router.put("/{mission_id}/speed", dependencies=[Operator])
async def set_speed(mission_id: MissionId, body: SpeedUpdate, missions: MissionsDep) -> MissionRead:
    """Simulated seconds per wall second; 0 pauses, "max" runs as fast as possible."""
    await missions.set_speed(mission_id, body.speed)
    return await _current(missions, mission_id)


@router.put("/{mission_id}/policy", dependencies=[Operator])
async def set_policy(
    mission_id: MissionId, body: PolicyUpdate, missions: MissionsDep
) -> MissionRead:
    """Switch the allocation policy; applies to auctions from now on and is recorded."""
    await missions.set_policy(mission_id, body.policy)
    return await _current(missions, mission_id)
