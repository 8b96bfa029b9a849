"""Scouts sweep their share of the outward spiral and auction each site they find."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from engine.geometry import Point, dist, first_entry
from engine.messages import Takeover
from engine.planning import Path, PlanningError
from engine.policies import OpenAuction
from engine.robots.base import Motion, Robot

if TYPE_CHECKING:
    from engine.context import MissionContext, SiteState


def site_task_id(x: float, y: float) -> str:
    return f"excavate@{x:.3f},{y:.3f}"


class Scout(Robot):
    rtype = "scout"
    capability = None

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
        self._rejoining = False

    def progress(self) -> int:
        return self.cursor

    def life(self) -> Any:
        grid = self.ctx.world.grid
        if self._rejoining:
            self._rejoining = False
            self.state = "idle"
            yield self.env.timeout(1.5 * self.ctx.scenario.protocol.heartbeat_s)
            if self._was_adopted():
                del self.route[self.cursor :]
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
                        self.ctx.emit("unreachable", robot=self.name, cell=cell)
                    else:
                        yield from self.sweep_to(path)
                        self.ctx.mark_scanned(cell)
                self.cursor += 1
            else:
                self.state = "idle"
                yield self.wait_for_wake()

    def sweep_to(self, path: Path) -> Any:
        """Drive a path, noticing every site that comes within the scan radius on the way."""
        r = self.ctx.scenario.scan_radius
        hits: list[tuple[float, int, SiteState]] = []
        along = 0.0
        for i in range(len(path) - 1):
            a, b = path[i], path[i + 1]
            seg = dist(a, b)
            for site in self.ctx.sites_near(a, b, r):
                u = first_entry(a, b, (site.x, site.y), r)
                if u is not None:
                    hits.append((along + u * seg, len(hits), site))
            along += seg
        hits.sort(key=lambda h: (h[0], h[1]))
        if not hits:
            yield from self.drive(path)
            return
        self.motion = Motion(float(self.env.now), path, along, self.speed)
        t0, done = float(self.env.now), 0.0
        for d, _, site in hits:
            if d > done:
                yield self.env.timeout(t0 + d / self.speed - float(self.env.now))
                done = d
            self.detect(site)
        if along > done:
            yield self.env.timeout(t0 + along / self.speed - float(self.env.now))
        self._end_motion(along)

    def detect(self, site: SiteState) -> None:
        self.ctx.note_site_found(site, self.name)
        tid = site_task_id(site.x, site.y)
        if tid in self.known_tasks:
            return
        self.known_tasks.add(tid)
        self.house.open("excavate", (site.x, site.y), tid, kind="scout_excavator")

    def on_task_heard(self, info: OpenAuction) -> None:
        if info.task_type == "excavate":
            self.known_tasks.add(info.task_id)

    def reauction(self, alloc: Any, hb: Any) -> None:
        super().reauction(alloc, None)  # a site does not move with its excavator

    # --- taking over a silent scout's cells ----------------------------------------------
    def adopt_extra(self, peer: str) -> list[int]:
        hb = self.ctx.liveness.last_heartbeat(self.name, peer)
        done = hb.progress if hb is not None else 0
        cells = self.routes.get(peer, [])[done:]
        self.route.extend(cells)
        self.wake()
        return cells

    def on_takeover_heard(self, msg: Takeover) -> None:
        if msg.cells:
            self.routes.setdefault(msg.sender, []).extend(msg.cells)

    def on_adoption_undone(self, failed: str) -> None:
        theirs = self.routes.get(failed, [])
        hb = self.ctx.liveness.last_heartbeat(self.name, failed)
        cells = set(theirs[hb.progress if hb is not None else 0 :])
        keep = self.route[: self.cursor] + [c for c in self.route[self.cursor :] if c not in cells]
        self.route[:] = keep

    def enable(self) -> None:
        self._rejoining = True
        super().enable()

    def _was_adopted(self) -> bool:
        """After a heartbeat period back: did a live peer take over my unscanned cells?"""
        board = self.ctx.liveness
        for name in self.ctx.robot_type_names("scout"):
            hb = board.last_heartbeat(self.name, name)
            if name != self.name and hb is not None and self.name in hb.adopted:
                return True
        return False
