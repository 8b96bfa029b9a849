"""Mission lifecycle: create, pause, resume, stop, speed and policy, plus the reads they need.

Every change goes the same way: check the mission is live, apply it under the engine gate
(between two steps of the stepping thread), commit the action with its simulation time,
then answer. Streaming follows from the engine's own events and `status` messages.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Sequence
from typing import Any

from app.db.models import Mission as MissionRow
from app.db.models import utcnow
from app.live.hub import Hub, Viewer, encode
from app.live.mission import LiveMission
from app.live.modes import is_field
from app.live.records import stream_state
from app.live.runner import MissionRunner
from app.services import queries
from app.services.admission import Admission, ProcessBudget
from app.services.errors import Conflict, LimitExceeded, NotFound
from app.services.field_links import link_fields
from app.services.field_rules import (
    Speed,
    check_field,
    check_field_speed,
    no_resume,
    processes_of,
    team_processes,
)
from app.services.live_state import LiveState, live_state
from app.services.replay import revive
from app.services.scenario_limits import check_size
from app.services.singleflight import SingleFlight
from app.services.store import Store
from app.settings import Settings
from engine import Mission, MissionInterface, Scenario, reference_scenario


def speed_value(speed: Speed) -> float | None:
    """API speed → runner speed (None is "max")."""
    return None if speed == "max" else float(speed)


class MissionService:
    """The operator's handle on missions; routes call this and nothing below it."""

    def __init__(self, settings: Settings, store: Store, runner: MissionRunner) -> None:
        self.settings = settings
        self.store = store
        self.runner = runner
        self.gate = runner.gate
        self.admission = Admission(settings.max_running_missions, runner.running_count)
        self.processes = ProcessBudget(
            settings.field_processes,
            lambda: sum(processes_of(lm.mission) for lm in runner.live.values()),
        )
        self._revivals: SingleFlight[None] = SingleFlight()

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

    async def detail(
        self, mission_id: int, metrics: bool = False
    ) -> tuple[MissionRow, LiveState | None]:
        """The stored row with the live state, if any; never a half-finished pair."""
        while True:
            await self.settled(mission_id)
            row = await self.row(mission_id)
            lm = self.runner.live.get(mission_id)
            if lm is None:
                return row, None
            if not lm.finishing:
                with self.gate:
                    return row, live_state(lm, metrics)

    async def current(self, mission_id: int) -> tuple[MissionRow, LiveState | None]:
        """Like `detail` but answered from memory while live (no database round trip)."""
        lm = self.runner.live.get(mission_id)
        if lm is not None and lm.row is not None and not lm.finishing:
            with self.gate:
                return lm.row, live_state(lm)
        return await self.detail(mission_id)

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
        field: bool = False,
    ) -> tuple[MissionRow, LiveState]:
        scenario = scenario or reference_scenario()
        if field:
            check_field(scenario, policy, speed, paused)
        check_size(self.settings, scenario)
        refusal = (
            f"{self.settings.max_running_missions} missions are already live; "
            "stop one or raise REGOLITH_MAX_RUNNING_MISSIONS"
        )
        with (
            self.admission.place(refusal),
            self.processes.reserve(team_processes(scenario) if field else 0),
        ):
            return await self._create(scenario, seed, policy, speed, paused, planner, field)

    async def _create(
        self,
        scenario: Scenario,
        seed: int,
        policy: str,
        speed: Speed,
        paused: bool,
        planner: str,
        field: bool = False,
    ) -> tuple[MissionRow, LiveState]:
        if field:
            mission, world = await asyncio.to_thread(
                self._build_field, scenario, seed, policy, speed_value(speed), paused
            )
        else:
            mission, world = await asyncio.to_thread(self._build, scenario, seed, policy, planner)
        paused = paused or speed == 0
        rate = 1.0 if speed == 0 else speed_value(speed)
        try:
            row = await self.store.create_mission(
                {
                    "scenario_name": scenario.name,
                    "scenario": scenario.model_dump(mode="json"),
                    "seed": seed,
                    "policy": policy,
                    "current_policy": policy,
                    "planner": planner,
                    "mode": "field" if field else "simulated",
                    "status": "paused" if paused else "running",
                    "speed": rate,
                    "started_at": None if paused else utcnow(),
                    "world_map": world,
                },
                link_fields(mission) if is_field(mission) else None,
            )
        except BaseException:
            mission.close()
            raise
        with self.gate:
            lm = self.runner.add(row.id, mission, speed=rate, paused=paused, row=row)
            return row, live_state(lm, metrics=True)

    def _build(
        self, scenario: Scenario, seed: int, policy: str, planner: str
    ) -> tuple[Mission, dict[str, Any]]:
        """Build a mission on a worker thread, holding the gate (building the planner seeds
        OMPL, so nothing may step meanwhile) but not the event loop."""
        with self.gate:
            mission = Mission(scenario, seed, policy, planner=planner)  # type: ignore[arg-type]
            return mission, mission.world_map()

    def _build_field(
        self, scenario: Scenario, seed: int, policy: str, speed: float | None, paused: bool
    ) -> tuple[MissionInterface, dict[str, Any]]:
        """A field mission: the world service and one agent process per robot, started
        here (paused: their clock stands from the start); the runner steps it like an
        engine mission (field/control.py)."""
        from field.control import FieldMission

        folder = (self.settings.data_dir / "field").resolve()  # journals, the world's log
        mission = FieldMission(
            scenario, seed, policy, float(speed or 20.0), folder=folder, paused=paused
        )
        return mission, mission.world_map()

    # -- lifecycle ---------------------------------------------------------------------

    async def _record(
        self, lm: LiveMission, t: float, kind: str, args: dict[str, Any], changes: dict[str, Any]
    ) -> None:
        action = {"t": t, "kind": kind, "args": args}
        await self.store.record_action(lm.id, action, False, changes)

    async def pause(self, mission_id: int) -> None:
        """Stop stepping it (a field mission: its world service's clock stands, and every
        agent's with it, field/clock.py)."""
        lm = await self.live(mission_id)
        with self.gate:
            t = self.runner.pause(lm)
        await self._record(lm, t, "pause", {}, {"status": "paused", "sim_time": t})

    async def resume(self, mission_id: int) -> None:
        """Continue a paused mission, or rebuild an interrupted one and continue it.

        Concurrent resumes of one interrupted mission share one rebuild (and its outcome):
        a second engine for the same mission would be built, replayed and leaked.
        """
        lm = self.runner.live.get(mission_id)
        if lm is None or self._revivals.busy(mission_id):
            await self._revivals.run(mission_id, lambda: self._revive(mission_id))
            return
        if lm.finishing:
            raise Conflict(f"mission {mission_id} is {lm.status}; it cannot be resumed")
        await self._go(lm)

    async def _revive(self, mission_id: int) -> None:
        lm = self.runner.live.get(mission_id)
        if lm is None:
            row = await self.row(mission_id)
            if row.status != "interrupted":
                raise Conflict(f"mission {mission_id} is {row.status}; it cannot be resumed")
            if row.mode == "field":
                raise Conflict(no_resume(mission_id))
            refusal = (
                f"{self.settings.max_running_missions} missions are already live; "
                "stop one before resuming another (REGOLITH_MAX_RUNNING_MISSIONS)"
            )
            with self.admission.place(refusal):
                lm = await revive(self.runner, self.store, row)
        elif lm.finishing:  # it came back live, and ended, before this rebuild started
            raise Conflict(f"mission {mission_id} is {lm.status}; it cannot be resumed")
        await self._go(lm)

    async def _go(self, lm: LiveMission) -> None:
        """Unpause a live mission and record it."""
        changes: dict[str, Any] = {"status": "running"}
        with self.gate:
            if lm.row is not None and lm.row.started_at is None:
                lm.row.started_at = changes["started_at"] = utcnow()
            t = changes["sim_time"] = self.runner.resume(lm)
        await self._record(lm, t, "resume", {}, changes)

    async def stop(self, mission_id: int) -> None:
        lm = await self.live(mission_id)
        with self.gate:
            t = float(lm.mission.now)
            task = self.runner.finish(lm, "stopped")
        await self._record(lm, t, "stop", {}, {})
        if task is not None:
            await task

    async def set_speed(self, mission_id: int, speed: Speed) -> None:
        if speed == 0:
            await self.pause(mission_id)
            return
        lm = await self.live(mission_id)
        if is_field(lm.mission):
            check_field_speed(speed)  # "max" has no meaning on the wall clock: 422
        with self.gate:
            t = self.runner.set_speed(lm, speed_value(speed))
        await self._record(lm, t, "speed", {"speed": speed}, {"speed": lm.speed})

    async def set_policy(self, mission_id: int, policy: str) -> None:
        lm = await self.live(mission_id)
        with self.gate:
            policy = lm.mission.set_policy(policy)
            action = self.engine_action(lm)
            lm.hub.publish(lm.status_message())
        await self.store.record_action(lm.id, action, True, {"current_policy": policy})

    def engine_action(self, lm: LiveMission) -> dict[str, Any]:
        """The command the engine just applied, in its replayable form; its events are
        streamed now so they precede any status message (caller holds the gate)."""
        self.runner.publish_pending(lm)
        return dict(lm.mission.actions[-1])

    # -- reads -------------------------------------------------------------------------

    async def page(
        self, status: str | None, policy: str | None, mode: str | None, limit: int, offset: int
    ) -> tuple[queries.Page[MissionRow], dict[int, LiveState]]:
        page = await self.store.read(queries.list_missions, status, policy, mode, limit, offset)
        states: dict[int, LiveState] = {}
        with self.gate:
            for r in page.items:
                lm = self.runner.live.get(r.id)
                if lm is not None and not lm.finishing:
                    states[r.id] = live_state(lm)
        return page, states

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
            with self.gate:
                return list(lm.mission.robot_list())
        row, state = await self.detail(mission_id)
        if state is not None:
            return await self.robots(mission_id)
        return list((row.final_state or {}).get("robots", []))

    async def watch(
        self, mission_id: int, ws: Any, render: Callable[[MissionRow, LiveState | None], Any]
    ) -> tuple[Hub, Viewer]:
        """Join a viewer to a mission's stream, its first message a snapshot.

        For a live mission the pending stream is flushed, the frame stream brought up to
        date, the snapshot taken and the viewer joined in one hold of the gate, so the viewer
        misses nothing and sees nothing twice: the snapshot carries the stream's `seq`, and
        its robots the stream's (rounded) poses, so the next delta applies to it exactly.
        A finished mission's snapshot has `seq` null (no deltas follow).
        """
        lm = self.runner.live.get(mission_id)
        if lm is None or lm.finishing or lm.row is None:
            row, state = await self.detail(mission_id)
            lm = self.runner.live.get(mission_id)
            if state is None or lm is None:
                message = {"mission": render(row, None), "map": row.world_map, "seq": None}
                state = stream_state(row.final_state)
                return self._join(mission_id, ws, {**message, "state": state})
            self.runner.note_row(lm, row)
        with self.gate:
            try:
                full, snap = self.runner.snapshot(lm)
                message = {"mission": render(lm.row, live_state(lm)), "map": lm.mission.world_map()}
                state = {**stream_state(snap), **{k: full[k] for k in ("scanned", "counters")}}
            except Exception as exc:  # its own data: it ends, alone, and the viewer is told
                self.runner.quarantine(lm, exc)
                raise Conflict(f"mission {mission_id} failed: {lm.crashed}") from None
            return self._join(mission_id, ws, {**message, "seq": full["seq"], "state": state})

    def _join(self, mission_id: int, ws: Any, message: dict[str, Any]) -> tuple[Hub, Viewer]:
        hub = self.runner.hub(mission_id)
        if len(hub) >= self.settings.max_viewers:
            self.runner.forget_hub(mission_id)
            raise LimitExceeded(f"at most {self.settings.max_viewers} viewers per mission")
        return hub, hub.join(ws, encode({"type": "snapshot", **message}))
