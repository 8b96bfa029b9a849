"""Mission control for a field mission: `FieldMission` is what the live service runs in place
of an engine `Mission` (both implement `engine.interface.MissionInterface`), built from what
mission control hears on the mission's key space, not from an engine it steps.

Events and auction records arrive from the agents and the world service; robots' poses and
distances from their heartbeats (field/odometer.py); the counters from the world service.
The event log, the views' shapes and the checks of an operator's task are the engine's own.
Operator commands become processes (disable: SIGKILL; enable: the same name again; add: a new
process) or commands on the key space (policy switch; pause, resume and speed: the world
service's clock, field/clock.py).
"""

from __future__ import annotations

import itertools
import math
import tempfile
import threading
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from engine.errors import CommandRejected, UnknownRobotError
from engine.events import Event, EventLog
from engine.geometry import point_along
from engine.interface import MissionInterface, MissionMode
from engine.placement import TaskPlacement, place_task
from engine.policies import resolve_policy
from engine.scenario import Scenario
from engine.team import robot_type
from engine.terrain import Terrain
from engine.views import MissionViews, tally
from field.intake import RecordView
from field.odometer import Odometer
from field.refusals import check_field
from field.world_handle import WorldHandle


class FieldMission(MissionViews):
    """A field mission as the live service sees it."""

    mode: MissionMode = "field"  # its agents keep the world service's clock (field/clock.py)

    def __init__(
        self,
        scenario: Scenario,
        seed: int,
        policy: str | int,
        speed: float,
        stall: str | None = None,
        folder: Path | None = None,
        handle: WorldHandle | None = None,
        first_seq: int = 0,
        paused: bool = False,
    ) -> None:
        """A new field mission (its world's process started, journals under `folder`, its
        clock standing from the start if `paused`), or, with `handle`, one a previous server
        started, attached to again: its events numbered on from `first_seq` (those stored)."""
        self.scenario, self.seed = scenario, seed
        self.initial_policy = resolve_policy(policy)
        if handle is None:
            folder = folder or Path(tempfile.gettempdir()) / "regolith-field"
            handle = WorldHandle.start(
                scenario, seed, self.initial_policy, speed, folder, stall, paused
            )
        self.fleet = handle
        self.world = self.fleet.world.world
        self.log = EventLog(lambda: self.now)
        self.log.emitted = first_seq
        # event number -> the life that reported it and its number there (stored with it:
        # a restarted server reads each life back from past what it stored)
        self.origins: dict[int, tuple[str, int]] = {}
        self.auctions: list[RecordView] = []
        self.actions: list[dict[str, Any]] = []
        self.status = "running"
        self._seen_events = 0
        self._poses: list[dict[str, Any]] = []  # taken in, not yet taken by the recorder
        self._seen_auctions: set[str] = set()
        self._taken: dict[str, dict[str, Any]] = {}  # each record as last taken in
        self._auction_watchers: list[Callable[[str], None]] = []
        self.odometer = Odometer()
        self._closed = False
        self._down: set[str] | None = None  # at the end: robots down before it stay down
        self._lock = threading.Lock()

    # --- what the runner reads --------------------------------------------------------------
    @property
    def now(self) -> float:
        f = self.terrain
        return float(f.finished_at) if f.finished_at is not None else self.fleet.now()

    @property
    def done(self) -> bool:
        return self.status != "running"

    @property
    def policy(self) -> str:
        return self.fleet.world.policy

    @property
    def terrain(self) -> Terrain:
        return self.fleet.world.terrain  # type: ignore[return-value]  # (what views read)

    @property
    def events(self) -> list[Event]:
        return self.log.events

    def processes(self) -> int:
        """Agent processes of this mission still running (the server's process budget)."""
        fleet = self.fleet
        procs = [*fleet.procs.values(), *([fleet.operator] if fleet.operator else [])]
        return sum(1 for p in procs if p.alive)

    def rejections(self) -> dict[str, Any]:
        """What this mission's processes dropped or refused from the bus: frames from
        strangers or in another's name, invalid reports (mission control), each agent's own
        count, what the world service's process dropped (counted with mission control's, by
        reason and sender), and requests the world service refused its members."""
        mine, world = self.fleet.intake.rejections(), self.fleet.world.dropped
        for part in ("by_reason", "by_sender"):
            merged = dict(mine[part])
            for k, n in (world.get(part) or {}).items():
                merged[k] = merged.get(k, 0) + int(n)
            mine[part] = dict(sorted(merged.items()))
        mine["total"] += int(world.get("total") or 0)
        return {**mine, "world_refused": self.fleet.world.refused}

    def subscribe(self, fn: Callable[[Event], None]) -> None:
        self.log.subscribe(fn)

    def watch_auctions(self, fn: Callable[[str], None]) -> None:
        """`fn(auction_id)` on every change of a record: it comes in a report of its own,
        often just after the event naming it, so the event alone would stream it unchanged."""
        self._auction_watchers.append(fn)

    def advance(self, until: float) -> None:
        """Take in what was heard since the last call (the agents run on their own clocks)."""
        if self.done:
            return
        self._take_in()
        if self.terrain.finished.triggered:
            self._end("completed")
        elif self.fleet.now() >= self.scenario.max_time_s:
            self._end("timeout")

    def _take_in(self) -> None:
        rec = self.fleet.intake
        with rec.lock:
            fresh = rec.events[self._seen_events :]
            self._seen_events = len(rec.events)
            poses, rec.poses = rec.poses, []  # (nobody else reads them: not kept twice)
            new_ids = [a for a in rec.auctions if a not in self._seen_auctions]
            changed = [a for a, r in rec.auctions.items() if self._taken.get(a) is not r]
            self._taken.update((a, rec.auctions[a]) for a in changed)
            heard = list(rec.heartbeats.items())
        with self._lock:
            self._poses.extend(poses)
        self._seen_auctions.update(new_ids)
        self.auctions.extend(RecordView(rec.auctions, a) for a in new_ids)
        self.odometer.heard(heard)
        for e in fresh:
            data = dict(e.get("data") or {})
            if e.get("by") not in (None, "world"):
                data.setdefault("robot", e["by"])
            ev = self.log.append_at(float(e.get("t", self.now)), str(e.get("event")), data)
            if e.get("src") is not None:
                self.origins[ev.seq] = (str(e["src"]), int(e["rseq"]))
        for fn, aid in itertools.product(self._auction_watchers, changed):
            fn(aid)

    def take_poses(self) -> list[dict[str, Any]]:
        """The robots' reported poses taken in since the last call (`{"robot", "t", "x", "y",
        "heading", "state", "load"}`), for the recorder to store: a field run is played back
        from them (`app/services/field_playback.py`), as it cannot be re-simulated."""
        with self._lock:
            out, self._poses = self._poses, []
        return out

    def _end(self, status: str) -> None:
        self.fleet.catch_up()  # every report up to the end, before the end is logged
        self._take_in()
        self.status = status
        makespan = self.terrain.finished_at
        self.log.emit("mission_ended", status=status, makespan_s=makespan)
        self.close()

    def close(self) -> None:
        """End the mission's processes (the world's and its agents)."""
        self._let_go(stop=True)

    def detach(self) -> None:
        """Let go of the mission and leave its processes running (a server that stops: the
        robots mine on, and the next server attaches again)."""
        self._let_go(stop=False)

    def _let_go(self, stop: bool) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._down = {n for n, p in self.fleet.procs.items() if not p.alive}
        self.fleet.close(stop=stop)

    # --- views ------------------------------------------------------------------------------
    def _robot(self, name: str, full: bool) -> dict[str, Any]:
        hb = self.fleet.intake.heartbeats.get(name)
        proc = self.fleet.procs.get(name)
        ended = self._down is not None and name not in self._down  # (its process ended with it)
        alive = proc is not None and (ended or proc.alive)
        rtype = robot_type(name)
        distance = self.odometer.metres.get(name, 0.0)
        if hb is None:
            x, y = self.fleet.world.starts.get(name, self.world.plant)
            heading, state, load = 0.0, "idle", 0
            path: tuple[tuple[float, float], ...] = ()
        else:
            speed = getattr(self.scenario.speeds, rtype)
            path = hb.path
            if len(path) >= 2 and alive:
                (x, y), heading = point_along(list(path), max(0.0, (self.now - hb.t) * speed))
                distance += math.dist((x, y), (hb.x, hb.y))  # since the last heartbeat
            else:
                x, y, heading = hb.x, hb.y, 0.0
            state, load = hb.state, hb.load
        d: dict[str, Any] = {
            "name": name,
            "type": rtype,
            "state": state if alive else "failed",
            "x": x,
            "y": y,
            "heading": heading,
            "load": load,
            "alive": alive,
        }
        if full:
            d.update(
                task=None,
                distance=distance,
                path=[[p[0], p[1]] for p in path],
                enabled=alive,
                partner=None,
            )
        return d

    def robot_dicts(self, full: bool) -> list[dict[str, Any]]:
        return [self._robot(n, full) for n in self.fleet.procs]

    def counters(self) -> dict[str, int]:
        recs = [a.to_dict() for a in self.auctions]
        bids = sum(len(a.get("bids") or ()) for a in recs)
        outcomes = [w["outcome"] for a in recs for w in a.get("awards") or ()]
        messages = self.fleet.intake.messages
        return tally(self.terrain, self.auctions, bids, outcomes.count("declined"), messages)

    def metrics(self) -> dict[str, Any]:
        return {
            **self.run_figures(),
            **self.counters(),
            "reauctions": sum(1 for a in self.auctions if a.to_dict().get("reauction_of")),
            "failures": sum(1 for a in self.actions if a["kind"] == "disable_robot"),
            "policy_changes": self.policy_changes(),
            **self.odometer.metrics(),
            "field": True,
            "processes": len(self.fleet.history),
            "rejections": self.rejections(),
            "transport": {"kind": "zenoh", "endpoint": self.fleet.endpoint},
        }

    # --- operator commands ------------------------------------------------------------------
    def _check_running(self) -> None:
        self.advance(self.now)
        if self.done:
            raise CommandRejected(f"mission has ended ({self.status})")

    def _record(self, kind: str, **args: Any) -> None:
        self.actions.append({"t": self.now, "kind": kind, "args": args})

    def set_policy(self, policy: str | int) -> str:
        self._check_running()
        try:
            name = resolve_policy(policy)
            check_field(policy=name)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None
        self._record("set_policy", policy=name)
        old = self.policy
        self.fleet.set_policy(name)
        self.log.emit("policy_changed", old=old, new=name)
        return name

    # --- the mission clock: every agent at once (field/clock.py) ------------------------------
    @property
    def paused(self) -> bool:
        return self.fleet.world.clock.paused

    @property
    def speed(self) -> float:
        return self.fleet.world.clock.speed

    def pause(self) -> float:
        """No robot acts until `resume`; the mission time it stands at."""
        self._check_running()
        return self.fleet.set_clock(paused=True)

    def resume(self) -> float:
        self._check_running()
        return self.fleet.set_clock(paused=False)

    def set_speed(self, speed: float | str) -> float:
        """Re-paced from now (paused or not); a speed field mode cannot run is refused."""
        self._check_running()
        try:
            check_field(speed=speed)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None
        return self.fleet.set_clock(speed=float(speed))

    def disable_robot(self, name: str, mode: str = "graceful") -> None:
        """Terrain mode has one way to stop a robot: its process is SIGKILLed (abrupt)."""
        self._check_running()
        proc = self.fleet.procs.get(name)
        if proc is None:
            raise UnknownRobotError(f"robot {name!r} does not exist in this mission")
        if not proc.alive:
            raise CommandRejected(f"robot {name!r} is already failed")
        self._record("disable_robot", name=name, mode="abrupt")
        try:
            self.fleet.kill(name)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None
        self.log.emit("robot_failed", robot=name)

    def enable_robot(self, name: str) -> None:
        self._check_running()
        proc = self.fleet.procs.get(name)
        if proc is None:
            raise UnknownRobotError(f"robot {name!r} does not exist in this mission")
        if proc.alive:
            raise CommandRejected(f"robot {name!r} is not disabled")
        self._record("enable_robot", name=name)
        try:
            self.fleet.spawn(name)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None
        self.log.emit("robot_enabled", robot=name)

    def add_robot(self, rtype: str, position: tuple[float, float] | None = None) -> str:
        self._check_running()
        if position is not None:
            raise CommandRejected("position: a field robot starts beside the plant")
        try:
            name = self.fleet.add(rtype)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None
        self._record("add_robot", type=rtype, position=None)
        self.log.emit("robot_added", robot=name, type=rtype)
        return name

    def inject_task(self, task_type: str = "excavate", location: Iterable[Any] = ()) -> str:
        """As `engine.Mission.inject_task`, but auctioned by the operator's console (an agent
        process) asked over the wire; in three steps, so a caller can leave the middle one,
        a round trip, outside its locks and event loop (app/services/commands.py)."""
        task = self.plan_injection(task_type, location)
        return self.record_injection(task, self.send_injection(task))

    def plan_injection(self, task_type: str, location: Iterable[Any]) -> TaskPlacement:
        """Checked and placed as a simulated mission places it; nothing sent or recorded yet."""
        self._check_running()
        sites = self.terrain.sites
        return place_task(self.world, sites, self.scenario.scan_radius, task_type, location)

    def send_injection(self, task: TaskPlacement) -> str:
        """The operator's console auctions it; the auction's id. Touches nothing of this
        object's: safe without the caller's locks."""
        try:
            return self.fleet.inject(task.task_type, (task.x, task.y), task.task_id)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None

    def record_injection(self, task: TaskPlacement, auction_id: str) -> str:
        self._record("inject_task", type=task.task_type, location=[task.x, task.y])
        self.log.emit(
            "task_injected", auction_id=auction_id, task_type=task.task_type, x=task.x, y=task.y
        )
        return auction_id


if TYPE_CHECKING:  # the type checker holds `FieldMission` to the mission interface
    _implements: type[MissionInterface] = FieldMission
