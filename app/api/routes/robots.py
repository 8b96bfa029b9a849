"""A mission's robots and operator tasks."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Body, status

from app.api.deps import CommandsDep, MissionId, MissionsDep, Operator, RobotName, Viewer
from app.api.schemas import RobotCreate, RobotDisable, RobotRead, TaskCreate, TaskCreated

router = APIRouter(prefix="/missions/{mission_id}", tags=["robots"])


@router.get("/robots", dependencies=[Viewer])
async def list_robots(mission_id: MissionId, missions: MissionsDep) -> list[RobotRead]:
    """Live robots (or their final state for a finished mission)."""
    return [RobotRead.model_validate(r) for r in await missions.robots(mission_id)]


@router.post("/robots", status_code=status.HTTP_201_CREATED, dependencies=[Operator])
async def add_robot(mission_id: MissionId, body: RobotCreate, commands: CommandsDep) -> RobotRead:
    """A new robot joins the running mission and takes part in auctions at once."""
    robot = await commands.add(mission_id, body.type, body.position)
    return RobotRead.model_validate(robot)


@router.post("/robots/{name}/disable", dependencies=[Operator])
async def disable_robot(
    mission_id: MissionId,
    name: RobotName,
    commands: CommandsDep,
    body: Annotated[RobotDisable | None, Body()] = None,
) -> RobotRead:
    """graceful (default): takes nothing new; abrupt: fails where it stands."""
    mode = (body or RobotDisable()).mode
    return RobotRead.model_validate(await commands.disable(mission_id, name, mode))


@router.post("/robots/{name}/enable", dependencies=[Operator])
async def enable_robot(mission_id: MissionId, name: RobotName, commands: CommandsDep) -> RobotRead:
    return RobotRead.model_validate(await commands.enable(mission_id, name))


@router.post("/tasks", status_code=status.HTTP_201_CREATED, dependencies=[Operator])
async def inject_task(
    mission_id: MissionId, body: TaskCreate, commands: CommandsDep
) -> TaskCreated:
    """An operator-initiated auction, run through the same protocol."""
    auction_id = await commands.inject_task(mission_id, body.type, body.location)
    return TaskCreated(auction_id=auction_id, type=body.type, location=body.location)
