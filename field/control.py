"""Mission control for a field mission: `FieldMission` is what the live service runs in place
of an engine `Mission` (the same methods the runner, the recorder and the views call), built
from what mission control hears on the mission's key space, not from an engine it steps.

Events and auction records arrive from the agents and the world service; robots' poses and
distances from their heartbeats (field/odometer.py); the counters from the world service.
Operator commands become processes (disable: SIGKILL; enable: the same name again; add: a new
process) or commands on the key space (policy switch).
"""

from __future__ import annotations

import itertools
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from engine.errors import CommandRejected, UnknownRobotError
from engine.events import Event
from engine.geometry import point_along
from engine.policies import POLICIES, resolve_policy
from engine.robots.scout import site_task_id
from engine.scenario import Scenario
from field.fleet import Fleet
from field.intake import RecordView
from field.odometer import Odometer


@dataclass(frozen=True)
class Injection:
    """An operator task checked and placed, to be sent to the operator's console."""

    task_type: str
    x: float
    y: float
    task_id: str


class FieldMission:
    """A field mission as the live service sees it (duck-types `engine.Mission`)."""

    mode = "field"  # as stored (missions.mode): its agents keep the wall clock × its speed

    def __init__(
        self,
        scenario: Scenario,
        seed: int,
        policy: str | int,
        speed: float,
        stall: str | None = None,
    ) -> None:
        self.scenario, self.seed = scenario, seed
        self.initial_policy = resolve_policy(policy)
        self.fleet = Fleet(scenario, seed, self.initial_policy, speed, stall=stall)
        self.world = self.fleet.world.world
        self.events: list[Event] = []
        self.auctions: list[RecordView] = []
        self.actions: list[dict[str, Any]] = []
        self.status = "running"
        self._subscribers: list[Callable[[Event], None]] = []
        self._seen_events = 0
        self._seen_auctions: set[str] = set()
        self._taken: dict[str, dict[str, Any]] = {}  # each record as last taken in
        self._auction_watchers: list[Callable[[str], None]] = []
        self.odometer = Odometer()
        self._closed = False
        self._down: set[str] | None = None  # at the end: robots down before it stay down
        self._lock = threading.Lock()
        self.fleet.up(operator=True)

    # --- what the runner reads --------------------------------------------------------------
    @property
    def now(self) -> float:
        f = self.fleet.world.field
        return float(f.finished_at) if f.finished_at is not None else self.fleet.now()

    @property
    def done(self) -> bool:
        return self.status != "running"

    @property
    def policy(self) -> str:
        return self.fleet.world.policy

    def processes(self) -> int:
        """Agent processes of this mission still running (the server's process budget)."""
        fleet = self.fleet
        procs = [*fleet.procs.values(), *([fleet.operator] if fleet.operator else [])]
        return sum(1 for p in procs if p.popen.poll() is None)

    def rejections(self) -> dict[str, Any]:
        """What this mission's processes dropped or refused from the bus: frames from
        strangers or in another's name, invalid reports (mission control), each agent's own
        count, and requests the world service refused its members."""
        return {**self.fleet.recorder.rejections(), "world_refused": self.fleet.world.refused}

    def subscribe(self, fn: Callable[[Event], None]) -> None:
        self._subscribers.append(fn)

    def watch_auctions(self, fn: Callable[[str], None]) -> None:
        """`fn(auction_id)` on every change of a record: it comes in a report of its own,
        often just after the event naming it, so the event alone would stream it unchanged."""
        self._auction_watchers.append(fn)

    def advance(self, until: float) -> None:
        """Take in what was heard since the last call (the agents run on their own clocks)."""
        if self.done:
            return
        self._take_in()
        if self.fleet.world.field.finished.triggered:
            self._end("completed")
        elif self.fleet.now() >= self.scenario.max_time_s:
            self._end("timeout")

    def _emit(self, t: float, kind: str, data: dict[str, Any]) -> None:
        ev = Event(len(self.events), float(t), kind, data)
        self.events.append(ev)
        for fn in self._subscribers:
            fn(ev)

    def _take_in(self) -> None:
        rec = self.fleet.recorder
        with rec.lock:
            fresh = rec.events[self._seen_events :]
            self._seen_events = len(rec.events)
            new_ids = [a for a in rec.auctions if a not in self._seen_auctions]
            changed = [a for a, r in rec.auctions.items() if self._taken.get(a) is not r]
            self._taken.update((a, rec.auctions[a]) for a in changed)
            heard = list(rec.heartbeats.items())
        self._seen_auctions.update(new_ids)
        self.auctions.extend(RecordView(rec.auctions, a) for a in new_ids)
        self.odometer.heard(heard)
        for e in fresh:
            data = dict(e.get("data") or {})
            if e.get("by") not in (None, "world"):
                data.setdefault("robot", e["by"])
            self._emit(float(e.get("t", self.now)), str(e.get("event")), data)
        for fn, aid in itertools.product(self._auction_watchers, changed):
            fn(aid)

    def _end(self, status: str) -> None:
        self.status = status
        makespan = self.fleet.world.field.finished_at
        self._emit(self.now, "mission_ended", {"status": status, "makespan_s": makespan})
        self.close()

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._down = {n for n, p in self.fleet.procs.items() if p.popen.poll() is not None}
        self.fleet.close()

    # --- views ------------------------------------------------------------------------------
    def world_map(self) -> dict[str, Any]:
        return self.world.to_dict()

    def _robot(self, name: str, full: bool) -> dict[str, Any]:
        hb = self.fleet.recorder.heartbeats.get(name)
        proc = self.fleet.procs.get(name)
        ended = self._down is not None and name not in self._down  # (its process ended with it)
        alive = proc is not None and (ended or proc.popen.poll() is None)
        rtype = name.rsplit("-", 1)[0]
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

    def _names(self) -> list[str]:
        return list(self.fleet.procs)

    def counters(self) -> dict[str, Any]:
        f = self.fleet.world.field
        recs = [a.to_dict() for a in self.auctions]
        return {
            "sites_found": f.sites_found,
            "sites_total": len(f.sites),
            "minerals_delivered": f.delivered,
            "minerals_total": f.minerals_total,
            "auctions": len(recs),
            "bids": sum(len(a.get("bids") or ()) for a in recs),
            "declines": [w["outcome"] for a in recs for w in a.get("awards") or ()].count(
                "declined"
            ),
            "reannouncements": sum(a.get("reannouncements") or 0 for a in recs),
            "messages": self.fleet.recorder.messages,
        }

    def frame(self) -> dict[str, Any]:
        f = self.fleet.world.field
        return {
            "t": self.now,
            "status": self.status,
            "policy": self.policy,
            "robots": [self._robot(n, False) for n in self._names()],
            "scanned": f.scanned_b64(),
            "scanned_count": f.scanned_count,
            "counters": self.counters(),
        }

    def robot_list(self) -> list[dict[str, Any]]:
        return [self._robot(n, True) for n in self._names()]

    def snapshot(self) -> dict[str, Any]:
        f = self.fleet.world.field
        return {
            "t": self.now,
            "status": self.status,
            "policy": self.policy,
            "scenario": self.scenario.name,
            "seed": self.seed,
            "robots": self.robot_list(),
            **f.picture(),
            "auctions": [a.to_dict() for a in self.auctions if a.status == "open"],
            "counters": self.counters(),
        }

    def metrics(self) -> dict[str, Any]:
        f = self.fleet.world.field
        return {
            "policy": self.initial_policy,
            "seed": self.seed,
            "scenario": self.scenario.name,
            "status": self.status,
            "completed": self.status == "completed",
            "makespan_s": f.finished_at,
            "sim_time_s": self.now,
            **{k: v for k, v in self.counters().items() if k != "minerals_delivered"},
            "minerals_delivered": f.delivered,
            "reauctions": sum(1 for a in self.auctions if a.to_dict().get("reauction_of")),
            "failures": sum(1 for a in self.actions if a["kind"] == "disable_robot"),
            "policy_changes": sum(1 for a in self.actions if a["kind"] == "set_policy"),
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
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None
        if not POLICIES[name].decentralized:  # as at creation (app check_field)
            raise CommandRejected(
                f"policy: {name} is centralized; field mode runs decentralized ones"
            )
        self._record("set_policy", policy=name)
        old = self.policy
        self.fleet.set_policy(name)
        self._emit(self.now, "policy_changed", {"old": old, "new": name})
        return name

    def disable_robot(self, name: str, mode: str = "graceful") -> None:
        """Field mode has one way to stop a robot: its process is SIGKILLed (abrupt)."""
        self._check_running()
        proc = self.fleet.procs.get(name)
        if proc is None:
            raise UnknownRobotError(f"robot {name!r} does not exist in this mission")
        if proc.popen.poll() is not None:
            raise CommandRejected(f"robot {name!r} is already failed")
        self._record("disable_robot", name=name, mode="abrupt")
        self.fleet.kill(name)
        self._emit(self.now, "robot_failed", {"robot": name})

    def enable_robot(self, name: str) -> None:
        self._check_running()
        proc = self.fleet.procs.get(name)
        if proc is None:
            raise UnknownRobotError(f"robot {name!r} does not exist in this mission")
        if proc.popen.poll() is None:
            raise CommandRejected(f"robot {name!r} is not disabled")
        self._record("enable_robot", name=name)
        self.fleet.spawn(name)
        self._emit(self.now, "robot_enabled", {"robot": name})

    def add_robot(self, rtype: str, position: tuple[float, float] | None = None) -> str:
        self._check_running()
        if position is not None:
            raise CommandRejected("position: a field robot starts beside the plant")
        try:
            name = self.fleet.add(rtype)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None
        self._record("add_robot", type=rtype, position=None)
        self._emit(self.now, "robot_added", {"robot": name, "type": rtype})
        return name

    def inject_task(self, task_type: str = "excavate", location: Any = ()) -> str:
        """As `engine.Mission.inject_task`, but auctioned by the operator's console (an agent
        process) asked over the wire; in three steps, so a caller can leave the middle one,
        a round trip, outside its locks and event loop (app/services/commands.py)."""
        injection = self.plan_injection(task_type, location)
        return self.record_injection(injection, self.send_injection(injection))

    def plan_injection(self, task_type: str, location: Any) -> Injection:
        """Checked and snapped; nothing sent or recorded yet."""
        self._check_running()
        if task_type not in ("excavate", "transport"):
            raise CommandRejected("type: must be 'excavate' or 'transport'")
        x, y = self._free_point(tuple(location), "location")
        task_id = f"{task_type}@{x:.3f},{y:.3f}"
        if task_type == "excavate":
            # snap to a site the robots know of, so the operator can point roughly at one
            near = [
                s
                for s in self.fleet.world.field.sites
                if s.found_at is not None
                and math.hypot(s.x - x, s.y - y) <= self.scenario.scan_radius
            ]
            if near:
                s = min(near, key=lambda s: (math.hypot(s.x - x, s.y - y), s.id))
                x, y, task_id = s.x, s.y, site_task_id(s.x, s.y)
        return Injection(task_type, x, y, task_id)

    def send_injection(self, injection: Injection) -> str:
        """The operator's console auctions it; the auction's id. Touches nothing of this
        object's: safe without the caller's locks."""
        i = injection
        try:
            return self.fleet.inject(i.task_type, (i.x, i.y), i.task_id)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None

    def record_injection(self, injection: Injection, auction_id: str) -> str:
        i = injection
        self._record("inject_task", type=i.task_type, location=[i.x, i.y])
        self._emit(
            self.now,
            "task_injected",
            {"auction_id": auction_id, "task_type": i.task_type, "x": i.x, "y": i.y},
        )
        return auction_id

    def _free_point(self, p: tuple[Any, ...], field: str) -> tuple[float, float]:
        """`engine.Mission._free_point`: two finite numbers, inside the area, not in a crater."""
        if len(p) != 2 or not all(isinstance(v, int | float) and math.isfinite(v) for v in p):
            raise CommandRejected(f"{field}: must be two finite numbers [x, y]")
        x, y = float(p[0]), float(p[1])
        w = self.world
        if not (0 <= x <= w.width and 0 <= y <= w.height):
            raise CommandRejected(
                f"{field}: ({x:g}, {y:g}) is outside the area 0..{w.width:g} × 0..{w.height:g}"
            )
        if not w.is_free(x, y):
            raise CommandRejected(f"{field}: ({x:g}, {y:g}) lies in a crater")
        return x, y

    def robot(self, name: str) -> Any:
        if name not in self.fleet.procs:
            raise UnknownRobotError(f"robot {name!r} does not exist in this mission")
        return self._robot(name, True)
