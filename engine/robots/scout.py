"""Scouts sweep their share of the outward spiral and auction each site they find."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from engine.geometry import Point, dist, first_entry, path_length
from engine.messages import Hello
from engine.planning import Path, PlanningError
from engine.robots.base import Robot
from engine.robots.search import Search

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.terrain import SiteState


def site_task_id(x: float, y: float) -> str:
    return f"excavate@{x:.3f},{y:.3f}"


class Scout(Robot):
    rtype = "scout"
    capability = None
    hears = frozenset({"excavate"})  # it auctions sites and learns of its peers' (`Search`)
    search: Search

    def __init__(
        self,
        name: str,
        ctx: MissionContext,
        pos: Point,
        speed: float,
        routes: dict[str, list[int]],
    ) -> None:
        super().__init__(name, ctx, pos, speed)
        self.search = Search(self, routes)

    def life(self) -> Any:
        grid = self.ctx.world.grid
        while self.recovery.rejoining:  # until my earlier duties are settled (`Recovery.rejoin`)
            self.state = "idle"
            yield self.wait_for_wake()
        while True:
            if self.leaving:
                self.go_quiet()
                return
            search = self.search
            if search.cursor < len(search.route):
                cell = search.route[search.cursor]
                goal = grid.waypoints[cell]
                self.state = "scanning"
                if goal is not None:
                    try:
                        path = self.ctx.planner.plan(self.pos, goal)
                    except PlanningError:
                        self.ctx.observer.emit("unreachable", robot=self.name, cell=cell)
                    else:
                        if self.charging is not None and not self._energy_for(path):
                            yield from self.charging.recharge()
                            continue  # then this cell again, from the charger
                        yield from self.sweep_to(path)
                        self.ctx.terrain.mark_scanned(cell)
                search.cursor += 1
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
            for site in self.ctx.terrain.sites_near(a, b, r):
                u = first_entry(a, b, (site.x, site.y), r)
                if u is not None:
                    hits.append((along + u * seg, len(hits), site))
            along += seg
        hits.sort(key=lambda h: (h[0], h[1]))
        if not hits:
            yield from self.mobility.drive(path)
            return
        speed = self.mobility.leg_speed()
        self.mobility.set_off(path, along, speed)
        t0, done = float(self.env.now), 0.0
        for d, _, site in hits:
            if d > done:
                yield self.env.timeout(t0 + d / speed - float(self.env.now))
                done = d
            self.detect(site)
        if along > done:
            yield self.env.timeout(t0 + along / speed - float(self.env.now))
        self.mobility.stop(along)

    def detect(self, site: SiteState) -> None:
        self.ctx.terrain.note_site_found(site, self.name)
        tid = site_task_id(site.x, site.y)
        known = self.search.known_tasks
        if tid in known:
            return
        known.add(tid)
        self.house.open("excavate", (site.x, site.y), tid, kind="scout_excavator")

    def on_rejoined(self) -> None:
        if self.search.wants_work():
            self.ctx.bus.publish(Hello(sender=self.name, rtype=self.rtype, wants_work=True))
        self.wake()
