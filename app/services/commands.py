"""Operator commands on a live mission's robots and tasks (the engine's fault-tolerance paths).

Input the engine would reject for a reason the operator can fix (a point outside the area)
is checked here first so the 422 names the field; the engine stays the final judge.
"""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Any

from app.live.mission import LiveMission
from app.live.modes import is_field
from app.services.errors import Conflict, Invalid, LimitExceeded, NotFound
from app.services.missions import MissionService
from engine import CommandRejected

if TYPE_CHECKING:
    from field.control import FieldMission

Point = tuple[float, float]


def _inside(lm: LiveMission, p: Point, loc: tuple[str | int, ...]) -> None:
    wm = lm.mission.world_map()
    width, height = float(wm["width"]), float(wm["height"])
    if not (0 <= p[0] <= width and 0 <= p[1] <= height):
        raise Invalid(f"{loc[-1]}: ({p[0]}, {p[1]}) is outside the {width}×{height} area", loc)


def _robot(lm: LiveMission, name: str) -> dict[str, Any]:
    for robot in lm.mission.robot_list():
        if robot["name"] == name:
            return dict(robot)
    raise NotFound(f"robot {name!r} not found in mission {lm.id}")


class RobotCommands:
    """Disable, enable and add robots; inject operator tasks."""

    def __init__(self, missions: MissionService) -> None:
        self.missions = missions
        self.gate = missions.gate

    async def _commit(self, lm: LiveMission, action: dict[str, Any]) -> None:
        await self.missions.store.record_action(lm.id, action, True, {})

    async def disable(self, mission_id: int, name: str, mode: str) -> dict[str, Any]:
        lm = await self.missions.live(mission_id)
        with self.gate:
            lm.mission.disable_robot(name, mode=mode)
            action = self.missions.engine_action(lm)
            robot = _robot(lm, name)
        await self._commit(lm, action)
        return robot

    async def enable(self, mission_id: int, name: str) -> dict[str, Any]:
        lm = await self.missions.live(mission_id)
        with self.gate:
            if is_field(lm.mission):  # its robot comes back as a new process
                self.missions.processes.check(1)
            lm.mission.enable_robot(name)
            action = self.missions.engine_action(lm)
            robot = _robot(lm, name)
        await self._commit(lm, action)
        return robot

    async def add(self, mission_id: int, rtype: str, position: Point | None) -> dict[str, Any]:
        lm = await self.missions.live(mission_id)
        limit = self.missions.settings.max_robots
        with self.gate:
            if len(lm.mission.robot_list()) >= limit:
                raise LimitExceeded(f"mission {mission_id} already has {limit} robots (the limit)")
            if is_field(lm.mission):  # a new process
                self.missions.processes.check(1)
            if position is not None:
                _inside(lm, position, ("body", "position"))
            try:
                name = lm.mission.add_robot(rtype, position)
            except CommandRejected as exc:
                raise Invalid(str(exc), ("body", "position" if position else "type")) from None
            action = self.missions.engine_action(lm)
            robot = _robot(lm, name)
        await self._commit(lm, action)
        return robot

    async def inject_task(self, mission_id: int, task_type: str, location: Point) -> str:
        lm = await self.missions.live(mission_id)
        if is_field(lm.mission):
            return await self._inject_over_the_wire(lm, lm.mission, task_type, location)
        with self.gate:
            _inside(lm, location, ("body", "location"))
            try:
                auction_id = lm.mission.inject_task(task_type=task_type, location=location)
            except CommandRejected as exc:
                raise Invalid(str(exc), ("body", "location")) from None
            action = self.missions.engine_action(lm)
        await self._commit(lm, action)
        return str(auction_id)

    async def _inject_over_the_wire(
        self, lm: LiveMission, mission: FieldMission, task_type: str, location: Point
    ) -> str:
        """A field mission's operator task goes to its console as a query: a round trip of
        up to 10 s while the console is busy, made on a worker thread without the gate (it
        held the event loop, every request and live frame of every mission, meanwhile)."""
        with self.gate:
            _inside(lm, location, ("body", "location"))
            try:
                injection = mission.plan_injection(task_type, location)
            except CommandRejected as exc:
                raise Invalid(str(exc), ("body", "location")) from None
        try:
            auction_id = await asyncio.to_thread(mission.send_injection, injection)
        except CommandRejected as exc:
            raise Conflict(str(exc)) from None
        with self.gate:
            mission.record_injection(injection, auction_id)
            action = self.missions.engine_action(lm)
        await self._commit(lm, action)
        return str(auction_id)
