"""Mission lifecycle: create, pause, resume, stop, speed and policy, plus the reads they need.

Every change goes the same way: check the mission is live, apply it (engine calls happen on
the loop thread, between runner slices), commit the action with its simulation time, then
answer. Streaming follows from the engine's own events and `status` messages.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

from app.db.models import Action, utcnow
from app.db.models import Mission as MissionRow
from app.runner import LiveMission, MissionRunner
from app.services import queries
from app.services.errors import Conflict, LimitExceeded, NotFound
from app.services.replay import revive
from app.services.store import Store
from app.settings import Settings
from engine import Mission, Scenario, reference_scenario

FINISHED = ("completed", "timeout", "stopped", "failed")
Speed = float | Literal["max"]


def speed_value(speed: Speed) -> float | None:
    """API speed → runner speed (None is "max")."""
    return None if speed == "max" else float(speed)


class MissionService:
    """The operator's handle on missions; routes call this and nothing below it."""

    def __init__(self, settings: Settings, store: Store, runner: MissionRunner) -> None:
        self.settings = settings
        self.store = store
        self.runner = runner

    # -- lookups -----------------------------------------------------------------------

    async def row(self, mission_id: int) -> MissionRow:
        row = await self.store.read(queries.get_mission, mission_id)
        if row is None:
            raise NotFound(f"mission {mission_id} not found")
        return row

    async def live(self, mission_id: int) -> LiveMission:
        """The live mission, or 404 (unknown) / 409 (finished or interrupted)."""
        lm = self.runner.live.get(mission_id)
        if lm is not None and not lm.finishing:
            return lm
        row = await self.row(mission_id)
        status = lm.status if lm is not None else row.status
        raise Conflict(f"mission {mission_id} is {status}; it accepts no commands")

    async def settled(self, mission_id: int) -> None:
        """Wait until a mission that is ending has written its final record."""
        lm = self.runner.live.get(mission_id)
        if lm is not None and lm.finishing and lm.final_task is not None:
            await lm.final_task

    # -- create ------------------------------------------------------------------------

    async def create(
        self,
        *,
        policy: str,
        seed: int,
        speed: Speed,
        paused: bool,
        scenario: Scenario | None,
        planner: str,
    ) -> tuple[MissionRow, LiveMission]:
        if self.runner.running_count() >= self.settings.max_running_missions:
            raise LimitExceeded(
                f"{self.settings.max_running_missions} missions are already live; "
                "stop one or raise REGOLITH_MAX_RUNNING_MISSIONS"
            )
        scenario = scenario or reference_scenario()
        mission = Mission(scenario, seed, policy, planner=planner)
        paused = paused or speed == 0
        rate = 1.0 if speed == 0 else speed_value(speed)
        row = await self.store.create_mission(
            {
                "scenario_name": scenario.name,
                "scenario": scenario.model_dump(mode="json"),
                "seed": seed,
                "policy": policy,
                "current_policy": policy,
                "planner": planner,
                "status": "paused" if paused else "running",
                "speed": rate,
                "started_at": None if paused else utcnow(),
                "world_map": mission.world_map(),
            }
        )
        lm = self.runner.add(row.id, mission, speed=rate, paused=paused)
        lm.row = row
        return row, lm

    # -- lifecycle ---------------------------------------------------------------------

    async def _record(
        self, lm: LiveMission, kind: str, args: dict[str, Any], changes: dict[str, Any]
    ) -> Action:
        action = {"t": float(lm.mission.now), "kind": kind, "args": args}
        return await self.store.record_action(lm.id, action, False, changes)

    async def pause(self, mission_id: int) -> None:
        lm = await self.live(mission_id)
        lm.paused = True
        lm.hub.publish(lm.status_message())
        await self._record(lm, "pause", {}, {"status": "paused", "sim_time": lm.mission.now})

    async def resume(self, mission_id: int) -> None:
        lm = self.runner.live.get(mission_id)
        if lm is None:
            row = await self.row(mission_id)
            if row.status != "interrupted":
                raise Conflict(f"mission {mission_id} is {row.status}; it cannot be resumed")
            if self.runner.running_count() >= self.settings.max_running_missions:
                raise LimitExceeded("too many live missions to resume another one")
            lm = await revive(self.runner, self.store, row)
            lm.paused = True
        elif lm.finishing:
            raise Conflict(f"mission {mission_id} is {lm.status}; it cannot be resumed")
        changes: dict[str, Any] = {"status": "running", "sim_time": lm.mission.now}
        if lm.row is None or lm.row.started_at is None:
            changes["started_at"] = utcnow()
            if lm.row is not None:
                lm.row.started_at = changes["started_at"]
        lm.paused = False
        lm.reanchor()
        self.runner.wake()
        lm.hub.publish(lm.status_message())
        await self._record(lm, "resume", {}, changes)

    async def stop(self, mission_id: int) -> None:
        lm = await self.live(mission_id)
        await self._record(lm, "stop", {}, {})
        task = self.runner.finish(lm, "stopped")
        if task is not None:
            await task

    async def set_speed(self, mission_id: int, speed: Speed) -> None:
        if speed == 0:
            await self.pause(mission_id)
            return
        lm = await self.live(mission_id)
        lm.speed = speed_value(speed)
        lm.reanchor()
        self.runner.wake()
        lm.hub.publish(lm.status_message())
        await self._record(lm, "speed", {"speed": speed}, {"speed": lm.speed})

    async def set_policy(self, mission_id: int, policy: str) -> None:
        lm = await self.live(mission_id)
        policy = lm.mission.set_policy(policy)
        lm.hub.publish(lm.status_message())
        await self.record_engine_action(lm, {"current_policy": policy})

    async def record_engine_action(self, lm: LiveMission, changes: dict[str, Any]) -> None:
        """Commit the command the engine just applied (its canonical, replayable form)."""
        action = dict(lm.mission.actions[-1])
        await self.store.record_action(lm.id, action, True, changes)

    # -- reads -------------------------------------------------------------------------

    async def detail(self, mission_id: int) -> tuple[MissionRow, LiveMission | None]:
        """The stored row with the live mission, if any; never a half-finished pair."""
        while True:
            await self.settled(mission_id)
            row = await self.row(mission_id)
            lm = self.runner.live.get(mission_id)
            if lm is None or not lm.finishing:
                return row, lm

    async def page(
        self, status: str | None, policy: str | None, limit: int, offset: int
    ) -> tuple[queries.Page[MissionRow], dict[int, LiveMission]]:
        page = await self.store.read(queries.list_missions, status, policy, limit, offset)
        return page, {r.id: self.runner.live[r.id] for r in page.items if r.id in self.runner.live}

    async def fresh(self, mission_id: int) -> None:
        """Make reads of a live mission's log see everything up to now (or 404)."""
        lm = self.runner.live.get(mission_id)
        if lm is None:
            await self.row(mission_id)
        elif lm.finishing:
            await self.settled(mission_id)
        else:
            await self.runner.flush(lm)

    async def robots(self, mission_id: int) -> Sequence[dict[str, Any]]:
        lm = self.runner.live.get(mission_id)
        if lm is not None and not lm.finishing:
            return list(lm.mission.robot_list())
        row, lm = await self.detail(mission_id)
        if lm is not None:
            return list(lm.mission.robot_list())
        return list((row.final_state or {}).get("robots", []))

    async def snapshot(self, mission_id: int) -> tuple[dict[str, Any], LiveMission | None]:
        """The parts of a `snapshot` message; for a live mission taken without awaiting."""
        lm = self.runner.live.get(mission_id)
        if lm is not None and not lm.finishing and lm.row is not None:
            m = lm.mission
            return {"row": lm.row, "map": m.world_map(), "state": m.snapshot()}, lm
        row, lm = await self.detail(mission_id)
        if lm is not None:
            return {"row": row, "map": lm.mission.world_map(), "state": lm.mission.snapshot()}, lm
        return {"row": row, "map": row.world_map, "state": row.final_state}, None
