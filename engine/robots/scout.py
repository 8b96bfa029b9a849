"""Scouts sweep their share of the outward spiral and auction each site they find."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from engine.geometry import Point, dist, first_entry, path_length
from engine.messages import Handoff, Hello, Takeover
from engine.planning import Path, PlanningError
from engine.policies import OpenAuction
from engine.robots.base import Robot
from engine.robots.core import Motion

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.field import SiteState


SHARE_MIN = 4
"""A scout shares its route only if each half would have at least this many cells."""


def site_task_id(x: float, y: float) -> str:
    return f"excavate@{x:.3f},{y:.3f}"


class Scout(Robot):
    rtype = "scout"
    capability = None
    hears = frozenset({"excavate"})  # it auctions sites and learns of its peers' (on_task_heard)

    def __init__(
        self,
        name: str,
        ctx: MissionContext,
        pos: Point,
        speed: float,
        routes: dict[str, list[int]],
    ) -> None:
        super().__init__(name, ctx, pos, speed)
        # every scout's plan: common knowledge at the start, then updated by Takeover messages
        self.routes = {k: list(v) for k, v in routes.items()}
        self.route: list[int] = routes.setdefault(name, [])
        self.cursor = 0
        self.known_tasks: set[str] = set()
        self._given: dict[str, tuple[str, list[int], float]] = {}  # handoff id → (to, cells, t)
        self._received: list[str] = []
        self._handoffs = 0
        self._reported = 0  # scan progress in my last heartbeat

    def progress(self) -> int:
        return self.cursor

    def life(self) -> Any:
        grid = self.ctx.world.grid
        while self.rejoining:  # until my earlier duties are settled (`Recovery.rejoin`)
            self.state = "idle"
            yield self.wait_for_wake()
        while True:
            if self.leaving:
                self.go_quiet()
                return
            if self.cursor < len(self.route):
                cell = self.route[self.cursor]
                goal = grid.waypoints[cell]
                self.state = "scanning"
                if goal is not None:
                    try:
                        path = self.ctx.planner.plan(self.pos, goal)
                    except PlanningError:
                        self.ctx.observer.emit("unreachable", robot=self.name, cell=cell)
                    else:
                        if self.battery is not None and not self._energy_for(path):
                            yield from self.recharge()
                            continue  # then this cell again, from the charger
                        yield from self.sweep_to(path)
                        self.ctx.field.mark_scanned(cell)
                self.cursor += 1
            elif self.ctx.radio is not None and not self.ctx.radio.in_contact(self.name):
                yield from self.regain_contact()  # its search is done: back within reach
            else:
                self.state = "idle"
                yield self.wait_for_wake()

    def _energy_for(self, path: Path) -> bool:
        """Enough to scan along this path and reach a charger from its end?"""
        energy, bat = self.ctx.energy, self.battery
        assert energy is not None and bat is not None
        if bat.level_at(float(self.env.now)) >= bat.capacity:
            return True  # full: charging cannot help (validation keeps this from happening)
        return energy.can_drive(self, path_length(path), path[-1], bat.spec.work_kw)

    def sweep_to(self, path: Path) -> Any:
        """Drive a path, noticing every site that comes within the scan radius on the way."""
        r = self.ctx.scenario.scan_radius
        hits: list[tuple[float, int, SiteState]] = []
        along = 0.0
        for i in range(len(path) - 1):
            a, b = path[i], path[i + 1]
            seg = dist(a, b)
            for site in self.ctx.field.sites_near(a, b, r):
                u = first_entry(a, b, (site.x, site.y), r)
                if u is not None:
                    hits.append((along + u * seg, len(hits), site))
            along += seg
        hits.sort(key=lambda h: (h[0], h[1]))
        if not hits:
            yield from self.drive(path)
            return
        speed = self.leg_speed()
        self.motion = Motion(float(self.env.now), path, along, speed)
        if self.battery is not None:
            self.energy_changed()
        t0, done = float(self.env.now), 0.0
        for d, _, site in hits:
            if d > done:
                yield self.env.timeout(t0 + d / speed - float(self.env.now))
                done = d
            self.detect(site)
        if along > done:
            yield self.env.timeout(t0 + along / speed - float(self.env.now))
        self._end_motion(along)

    def detect(self, site: SiteState) -> None:
        self.ctx.field.note_site_found(site, self.name)
        tid = site_task_id(site.x, site.y)
        if tid in self.known_tasks:
            return
        self.known_tasks.add(tid)
        self.house.open("excavate", (site.x, site.y), tid, kind="scout_excavator")

    def on_task_heard(self, info: OpenAuction) -> None:
        if info.task_type == "excavate":
            self.known_tasks.add(info.task_id)

    # --- taking over a silent scout's cells ----------------------------------------------
    def adopt_extra(self, peer: str) -> list[int]:
        hb = self.ctx.liveness.last_heartbeat(self.name, peer)
        done = hb.progress if hb is not None else 0
        cells = self.routes.get(peer, [])[done:]
        self.route.extend(cells)
        self.wake()
        return cells

    def on_takeover_heard(self, msg: Takeover) -> None:
        theirs = self.routes.setdefault(msg.sender, [])
        known = set(theirs)
        theirs.extend(c for c in msg.cells if c not in known)  # said again on a return

    def on_adoption_undone(self, failed: str) -> None:
        theirs = self.routes.get(failed, [])
        hb = self.ctx.liveness.last_heartbeat(self.name, failed)
        cells = set(theirs[hb.progress if hb is not None else 0 :])
        keep = self.route[: self.cursor] + [c for c in self.route[self.cursor :] if c not in cells]
        self.route[:] = keep

    # --- sharing the search with a scout that has none -------------------------------------
    def heartbeat(self) -> None:
        self._reported = self.cursor
        super().heartbeat()

    def remaining(self) -> int:
        """Cells still to scan beyond the one being driven to."""
        return max(0, len(self.route) - self.cursor - 1)

    def wants_work(self) -> bool:
        return self.remaining() == 0

    def handoffs_received(self) -> tuple[str, ...]:
        return tuple(self._received)

    def on_hello_heard(self, msg: Hello) -> None:
        if msg.rtype == "scout" and msg.wants_work and self.participating:
            self._maybe_share(msg.sender)

    def _maybe_share(self, to: str) -> None:
        """The scout with the longest remaining route (as far as I know) gives the newcomer
        the far half of it; everyone else stays put (and a scout still settling its earlier
        duties does not give any away)."""
        mine = self.remaining()
        if mine < 2 * SHARE_MIN or self.rejoining:
            return
        # rank everyone, me included, by what the last heartbeats said: the same data for all
        # scouts, so they agree on the donor
        reported = len(self.route) - self._reported
        board = self.ctx.liveness
        for name in self.peers_of_type("scout"):
            if name in (self.name, to) or name in self.down or not self.peer_alive(name):
                continue
            hb = board.last_heartbeat(self.name, name)
            theirs = len(self.routes.get(name, [])) - (hb.progress if hb is not None else 0)
            if theirs > reported or (theirs == reported and name < self.name):
                return
        cells = self.route[-(mine // 2) :]
        del self.route[-(mine // 2) :]
        self._handoffs += 1
        hid = f"{self.name}>{to}#{self._handoffs}"
        self._given[hid] = (to, cells, float(self.env.now))
        self.routes.setdefault(to, []).extend(cells)
        self.ctx.observer.emit("handoff", by=self.name, to=to, cells=len(cells), handoff_id=hid)
        self.ctx.bus.publish(Handoff(sender=self.name, to=to, cells=tuple(cells), handoff_id=hid))

    def on_handoff_heard(self, msg: Handoff) -> None:
        if msg.to == self.name:
            if msg.handoff_id not in self._received:
                self._received.append(msg.handoff_id)
                self.route.extend(msg.cells)
                self.wake()
            return
        moved = set(msg.cells)
        donor = self.routes.get(msg.sender, [])
        self.routes[msg.sender] = [c for c in donor if c not in moved]
        self.routes.setdefault(msg.to, []).extend(msg.cells)

    def check_peers(self) -> None:
        super().check_peers()
        board, proto = self.ctx.liveness, self.ctx.scenario.protocol
        for hid, (to, cells, t) in list(self._given.items()):
            hb = board.last_heartbeat(self.name, to)
            if hb is not None and hid in hb.received:
                del self._given[hid]  # confirmed: the cells are theirs
            elif to in self.down or self.env.now - t > 3 * proto.heartbeat_s:
                # unconfirmed: scan them myself (at worst twice, never not at all)
                del self._given[hid]
                self.route.extend(cells)
                self.ctx.observer.emit("handoff_taken_back", by=self.name, to=to, handoff_id=hid)
                self.wake()

    def on_cells_taken(self, cells: tuple[int, ...]) -> None:
        """A peer scans these of my remaining cells now (it adopted them while I was down)."""
        taken = set(cells)
        self.route[self.cursor :] = [c for c in self.route[self.cursor :] if c not in taken]

    def on_rejoined(self) -> None:
        if self.wants_work():
            self.ctx.bus.publish(Hello(sender=self.name, rtype=self.rtype, wants_work=True))
        self.wake()
