"""The world service: the field's ground truth, served to the robots over Zenoh queries.

It runs in a process of its own (`field.world_process`; `regolith fleet` runs it beside mission
control). It holds the engine's own `Terrain` (the sites and their piles, the minerals on the
ground, the scanned cells, the deliveries) on the mission's clock (`field.clock`), and answers
one operation per query on `regolith/<mission>/world` (docs/field.md lists them). A robot
learns of a site only by asking what lies within its scan radius along the segment it just
drove, or what pile lies where it stands.
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import simpy

from engine.geometry import first_entry
from engine.observer import Observer
from engine.policies import resolve_policy
from engine.scenario import ROBOT_TYPES, Scenario
from engine.team import robot_type, roster, start_positions
from engine.terrain import SiteState, Terrain
from engine.world import generate_world
from field.clock import MissionClock
from field.drain import Drain
from field.journal import Journal
from field.journal import serve as serve_journal
from field.link import Link
from field.trust import Certificate, Rejected, Rejections
from field.wire import event_key, journal_key, presence_key, world_key
from field.world_rules import CHANGES, PAUSED, Paused, Refused, authorize

log = logging.getLogger("regolith.field.world")


class _TerrainEnv:
    """What `engine.terrain.Terrain` reads of its environment: the time and an event factory."""

    def __init__(self, clock: MissionClock) -> None:
        self._clock = clock
        self._env = simpy.Environment()

    @property
    def now(self) -> float:
        return self._clock.now()

    def event(self) -> simpy.Event:
        return self._env.event()


def site_dict(s: SiteState) -> dict[str, Any]:
    return {
        "id": s.id,
        "x": s.x,
        "y": s.y,
        "total": s.total,
        "remaining": s.remaining,
        "found_at": s.found_at,
        "worker": s.worker,
        "last_worker": s.last_worker,
    }


class WorldService:
    def __init__(
        self,
        link: Link,
        scenario: Scenario,
        seed: int,
        policy: str,
        speed: float,
        on_event: Callable[[dict[str, Any]], None] | None = None,
        journal: Path | None = None,
    ) -> None:
        mission, session = link.mission, link.session
        self.link = link
        self.mission, self.scenario, self.seed, self.speed = mission, scenario, seed, speed
        self.policy = resolve_policy(policy)
        world_rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(4)[0])
        self.world = generate_world(scenario, world_rng)
        self.clock = MissionClock.start(speed)
        self.observer = Observer(self.clock.now)
        self.terrain = Terrain(self.world, _TerrainEnv(self.clock), self.observer)  # type: ignore[arg-type]
        self.roster: dict[str, str] = roster(scenario.team)
        starts = start_positions(self.world, scenario.start_spread, len(self.roster))
        self.starts = dict(zip(self.roster, starts, strict=True))
        self.spawned: dict[str, int] = {}
        self.loads: dict[str, int] = {}  # minerals on board, by robot (bucket or bin)
        # `once` id -> the answer of the operation carried out under it (False for one
        # settled as never done): a mineral moves once even when a reply is lost
        self.done: dict[str, Any] = {}
        self.seen: dict[str, tuple[float, float, float]] = {}  # robot -> (t, x, y) last heard
        self.heard: dict[str, float] = {}  # robot -> mission time it was last heard
        self.revealed: dict[str, set[str]] = {}  # robot -> the sites the world showed it
        self.queries = 0
        self.views = 0  # numbers each view: a later one was read later (`WorldView.show`)
        # requests from members that they may not make, or cannot be carried out
        self.refusals = Rejections(f"world service {mission}")
        self._lock = threading.Lock()
        self._flush_lock = threading.Lock()
        self._outbox: deque[bytes] = deque()
        self._session = session
        self._on_event = on_event
        self._events_pub = session.declare_publisher(event_key(mission, "world"))
        # its events, numbered and kept: mission control reads back what it missed
        self.journal = Journal("world", link.cred.gen, journal)
        self._journal_query = Drain(
            session.declare_queryable,
            journal_key(mission, "world"),
            lambda q: serve_journal(link, self.journal, journal_key(mission, "world"), q),
            "world journal",
        )
        self.observer.log.subscribe(self._publish_event)
        self._queryable = Drain(
            session.declare_queryable, world_key(mission), self._on_query, "world service"
        )
        self._presence = session.liveliness().declare_token(presence_key(mission))

    def _publish_event(self, ev: Any) -> None:
        """Recorded now (the world's lock is held), published by `_flush` once it is not:
        a Zenoh put while holding the lock every query waits for can stall the service."""
        data = {"kind": "event", "t": ev.t, "event": ev.kind, "data": ev.data, "by": "world"}
        if self._on_event is not None:
            self._on_event(data)
        data = self.journal.record(data)
        self._outbox.append(self.link.seal(event_key(self.mission, "world"), data))

    def _flush(self) -> None:
        with self._flush_lock:  # one publisher at a time, in the order they happened
            while self._outbox:
                self._events_pub.put(self._outbox.popleft())

    def _on_query(self, query: Any) -> None:
        """A signed request from a member of the mission (anything else is dropped and
        counted, unanswered), checked against what its asker may do (`world_rules`)."""
        got = self.link.take_query(query, world_key(self.mission))
        if got is None:
            return
        opened, req = got
        args = req.get("args")
        try:
            if not isinstance(req.get("op"), str) or not isinstance(args or {}, dict):
                reply: dict[str, Any] = {"ok": False, "error": "malformed request"}
            else:
                with self._lock:  # (held by `set_clock` too: nothing changes once paused)
                    self.queries += 1
                    reply = {"ok": True, "value": self.handle(req["op"], args or {}, opened.cert)}
        except Paused:
            reply = {"ok": False, "error": PAUSED}  # not a refusal: not counted as one
        except (KeyError, TypeError, ValueError, IndexError, OverflowError) as exc:
            why = "refused" if isinstance(exc, Refused) else "bad request"
            self.refusals.count(Rejected(why, opened.sender, str(exc)[:200]))
            reply = {"ok": False, "error": str(exc)[:200]}
        # every answer carries the clock: an asker that missed a change catches up at once
        reply["clock"] = self.clock.state.to_dict()
        self.link.reply(query, world_key(self.mission), req, reply)
        self._flush()

    # --- the operations -------------------------------------------------------------------
    def handle(self, op: str, a: dict[str, Any], caller: Certificate) -> Any:
        """One operation, asked by `caller` (`Refused` if it may not). One that moves a
        mineral carries a `once` id, and is carried out once whatever the number of times it
        is asked: an agent asks again when a reply is late, and a delivery asked twice would
        count a mineral twice. (A repeat is answered as the first time, before the checks: the
        first one changed what they read.)"""
        if op in CHANGES and self.clock.paused:  # (a repeat under `once` too: simplest)
            raise Paused(op)
        once = a.get("once")
        if once is not None and op != "settle" and str(once) in self.done:
            return self.done[str(once)]
        authorize(self, op, a, caller)
        if once is None:
            return self._handle(op, a, caller.name)
        if op == "settle":  # the asker heard no answer: did it happen? (if not, it never will)
            return self.done.setdefault(str(once), False)
        self.done[str(once)] = self._handle(op, a, caller.name)
        return self.done[str(once)]

    def _handle(self, op: str, a: dict[str, Any], caller: str) -> Any:
        f = self.terrain
        if op == "spawn":
            return self._spawn(str(a["name"]))
        if op == "site_at":
            s = f.site_at((float(a["x"]), float(a["y"])))
            return None if s is None else self._reveal(caller, s)
        if op == "site":
            return site_dict(self.site(a["id"]))
        if op == "sites_near":
            p, q, r = (
                (float(a["ax"]), float(a["ay"])),
                (float(a["bx"]), float(a["by"])),
                float(a["r"]),
            )
            r = min(r, self.scenario.scan_radius)  # a scout sees no farther than its scanner
            return [
                self._reveal(caller, s)
                for s in f.sites_near(p, q, r)
                if first_entry(p, q, (s.x, s.y), r) is not None
            ]
        if op == "site_set":
            s = self.site(a["id"])
            before = s.remaining
            for key in ("remaining", "worker", "last_worker"):
                if key in a:
                    setattr(s, key, int(a[key]) if key == "remaining" else a[key])
            if "remaining" in a:
                self.observer.progress_at = self.clock.now()
                if "by" in a and s.remaining < before:  # dug: out of the pile, into the bucket
                    self._hold(str(a["by"]), before - s.remaining, (s.x, s.y))
            return site_dict(s)
        if op == "found":
            f.note_site_found(self.site(a["id"]), str(a["by"]))
            return None
        if op == "scan":
            f.mark_scanned(int(a["cell"]))
            return None
        if op == "ground":
            return [self._ground_dict(g) for g in f.ground]
        if op == "drop":
            p = (float(a["x"]), float(a["y"]))
            self._hold(str(a["by"]), -1, p)
            f.drop_mineral(p, str(a["by"]))
            return None
        if op == "pick":
            g = next((g for g in f.ground if g.id == a["id"]), None)
            if g is None:
                return False
            f.pick_ground(g, str(a["by"]))
            self._hold(str(a["by"]), 1, (g.x, g.y))
            return True
        if op == "handover":  # a hauler takes the mineral in an excavator's bucket
            p = (float(a["x"]), float(a["y"]))
            self._hold(str(a["src"]), -1, p)
            self._hold(str(a["by"]), 1, p)
            return True
        if op == "deliver":
            self._hold(str(a["by"]), -1, self.world.plant)
            f.note_delivery(str(a["by"]))
            return None
        if op == "status":
            return self.status()
        raise ValueError(f"op: unknown operation {op!r}")

    # --- what each robot carries, and a robot's death ------------------------------------------
    def _hold(self, name: str, n: int, p: tuple[float, float]) -> None:
        """`name` took on (n > 0) or let go of (n < 0) minerals at p: the world's record of its
        bucket or bin, kept from the operations that move a mineral (dig, hand-over, pick-up,
        drop, delivery), each one query, so a mineral is always in exactly one place here."""
        self.loads[name] = max(0, self.loads.get(name, 0) + n)
        self._saw(name, self.clock.now(), p)

    def _saw(self, name: str, t: float, p: tuple[float, float]) -> None:
        if t >= self.seen.get(name, (-math.inf, 0.0, 0.0))[0]:
            self.seen[name] = (t, float(p[0]), float(p[1]))

    def note_heard(self, name: str, pos: tuple[float, float] | None = None) -> None:
        """Mission control heard a message from `name` (with a position: a heartbeat).

        Called on Zenoh's subscriber thread: it takes no lock (the query handler holds the
        world's lock while it publishes events; a subscriber waiting for that lock stalled
        the world service, every agent waiting for an answer). Two dict writes: at worst a
        position a moment older is kept."""
        now = self.clock.now()
        self.heard[name] = now
        if pos is not None:
            self._saw(name, now, pos)

    def robot_lost(self, name: str) -> int:
        """`name` died (SIGKILL, a crash, silence): as `Robot.fail` → `drop_loads` in the
        engine, what it carried falls to the ground where it was last heard of (a heartbeat's
        position, or where it last took a mineral on, whichever is later) and a site it was
        digging has no worker any more. The excavators' ground-mineral auctions and the
        recovery transports of its peers take it from there. Idempotent; the number dropped."""
        with self._lock:
            n = self._settle(name)
        self._flush()
        return n

    def _settle(self, name: str) -> int:
        n = self.loads.pop(name, 0)
        _t, x, y = self.seen.get(name, (0.0, *self.starts.get(name, self.world.plant)))
        for _ in range(n):
            self.terrain.drop_mineral((x, y), name)
        for s in self.terrain.sites:
            if s.worker == name:
                s.worker = None
        return n

    @property
    def refused(self) -> int:
        return self.refusals.total

    def minerals_in(self) -> dict[str, int]:
        """Where every mineral is, read at one instant: they add up to the total."""
        with self._lock:
            return self._minerals()

    def _minerals(self) -> dict[str, int]:
        f, sites = self.terrain, sum(s.remaining for s in self.terrain.sites)
        aboard = sum(self.loads.values())
        return {"sites": sites, "aboard": aboard, "ground": len(f.ground), "delivered": f.delivered}

    def _reveal(self, name: str, s: SiteState) -> dict[str, Any]:
        """A site shown to `name`: the only ones it may report found."""
        self.revealed.setdefault(name, set()).add(s.id)
        return site_dict(s)

    def site(self, site_id: Any) -> SiteState:
        for s in self.terrain.sites:
            if s.id == site_id:
                return s
        raise ValueError(f"id: no site {site_id!r}")

    @staticmethod
    def _ground_dict(g: Any) -> dict[str, Any]:
        return {"id": g.id, "x": g.x, "y": g.y, "dropped_at": g.dropped_at}

    def _spawn(self, name: str) -> dict[str, Any]:
        rtype = robot_type(name)
        if rtype not in (*ROBOT_TYPES, "operator"):
            raise ValueError(f"name: {name!r} must be scout-N, excavator-N or hauler-N")
        times = self.spawned.get(name, 0)
        self.spawned[name] = times + 1
        if times:  # a new life: its last one ended, settled or not yet (the lock is held)
            self._settle(name)
        pos = self.starts.get(name) or start_positions(self.world, self.scenario.start_spread, 1)[0]
        if rtype == "operator":  # the operator's console: an auctioneer with no body
            pos = self.world.plant
        return {
            "rtype": rtype,
            "pos": list(pos),
            "roster": self.roster,
            "joined_late": name not in self.roster or times > 0,
            "scenario": self.scenario.model_dump(mode="json"),
            "seed": self.seed,
            "policy": self.policy,
            "clock": self.clock.state.to_dict(),
            "speed": self.clock.speed,
        }

    def status(self) -> dict[str, Any]:
        f = self.terrain
        return {
            "t": self.clock.now(),
            "delivered": f.delivered,
            "minerals_total": f.minerals_total,
            "sites_found": f.sites_found,
            "sites_total": len(f.sites),
            "ground": len(f.ground),
            "aboard": sum(self.loads.values()),
            "sites_remaining": sum(s.remaining for s in f.sites),
            "scanned": f.scanned_count,
            "finished": f.finished.triggered,
            "finished_at": f.finished_at,
            "clock": self.clock.state.to_dict(),
        }

    def view(self) -> dict[str, Any]:
        """What mission control shows of the world, read at one instant (`field.world_process`)."""
        with self._lock:
            self.views += 1
            return {
                "seq": self.views,
                "status": self.status(),
                "picture": self.terrain.picture(),
                "minerals_in": self._minerals(),
                "loads": dict(self.loads),
                "policy": self.policy,
                "clock": self.clock.state.to_dict(),
                "queries": self.queries,
                "late": self.link.late,
                "refusals": self.refusals.snapshot(),
            }

    def set_clock(self, paused: bool | None = None, speed: float | None = None) -> dict[str, Any]:
        """Pause, resume or re-pace the mission (mission control): re-anchored at the world's
        own now; the new state, for mission control to publish to every agent."""
        with self._lock:
            state = self.clock.set(paused=paused, speed=speed)
            self.speed = state.speed
        return state.to_dict()

    def close(self) -> None:
        self._queryable.undeclare()
        self._journal_query.undeclare()
        self.journal.close()
        for decl in (self._presence, self._events_pub):
            with contextlib.suppress(Exception):  # the session may be gone already
                decl.undeclare()  # type: ignore[no-untyped-call]
