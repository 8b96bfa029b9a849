"""The terrain, the physical state of the mission's area: the sites and their piles, the
minerals lying on the ground, the cells scanned, the deliveries at the plant, and whether the
mission is finished.

It is shared because it is physical: a robot senses what lies where it stands (the pile at
its site, a mineral at its feet). What happens here is reported to the observer, in the
order it happens.
"""

from __future__ import annotations

import base64
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from engine.geometry import Point, dist

if TYPE_CHECKING:
    import simpy

    from engine.observer import Observer
    from engine.world import World

NEAR = 0.5
"""Two points this close are the same place (a robot at a site, a mineral at a spot)."""


@dataclass(slots=True)
class SiteState:
    id: str
    x: float
    y: float
    total: int
    remaining: int
    found_at: float | None = None
    worker: str | None = None
    last_worker: str | None = None


@dataclass(slots=True)
class GroundMineral:
    """A mineral lying on the ground (fell from a failed robot), waiting for a transport."""

    id: str
    x: float
    y: float
    dropped_at: float


class Terrain:
    def __init__(self, world: World, env: simpy.Environment, observer: Observer) -> None:
        self.world = world
        self.env = env
        self.observer = observer
        self.sites = [SiteState(s.id, s.x, s.y, s.minerals, s.minerals) for s in world.sites]
        self.ground: list[GroundMineral] = []
        self.ground_serial = 0
        self.delivered = 0
        self.minerals_total = sum(s.total for s in self.sites)
        self.sites_found = 0
        self.scanned = bytearray(world.grid.cols * world.grid.rows)
        self.scanned_count = 0
        self.scan_visits = 0
        self.finished = env.event()
        self.finished_at: float | None = None
        self._site_cells: dict[tuple[int, int], list[SiteState]] = {}
        g = world.grid
        for site in self.sites:
            key = (int(site.x // g.cell_w), int(site.y // g.cell_h))
            self._site_cells.setdefault(key, []).append(site)

    def site_at(self, p: Point) -> SiteState | None:
        for s in self.sites:
            if abs(s.x - p[0]) <= NEAR and abs(s.y - p[1]) <= NEAR:
                return s
        return None

    def sites_near(self, a: Point, b: Point, r: float) -> list[SiteState]:
        """Sites that could lie within r of the segment a–b (a cheap spatial pre-filter)."""
        g = self.world.grid
        c0, c1 = int((min(a[0], b[0]) - r) // g.cell_w), int((max(a[0], b[0]) + r) // g.cell_w)
        r0, r1 = int((min(a[1], b[1]) - r) // g.cell_h), int((max(a[1], b[1]) + r) // g.cell_h)
        out: list[SiteState] = []
        for cx in range(c0, c1 + 1):
            for cy in range(r0, r1 + 1):
                out.extend(self._site_cells.get((cx, cy), ()))
        return out

    def drop_mineral(self, p: Point, by: str) -> None:
        self.ground_serial += 1
        g = GroundMineral(f"ground-{self.ground_serial}", p[0], p[1], float(self.env.now))
        self.ground.append(g)
        self.observer.dropped += 1
        self.observer.emit("mineral_dropped", robot=by, x=p[0], y=p[1], mineral=g.id)

    def ground_near(self, p: Point, radius: float = NEAR) -> GroundMineral | None:
        for g in self.ground:
            if dist((g.x, g.y), p) <= radius:
                return g
        return None

    def pick_ground(self, g: GroundMineral, by: str) -> None:
        self.ground.remove(g)
        self.observer.recovered += 1
        self.observer.emit("mineral_recovered", robot=by, x=g.x, y=g.y, mineral=g.id)

    def mark_scanned(self, cell: int) -> None:
        self.scan_visits += 1
        if not self.scanned[cell]:
            self.scanned[cell] = 1
            self.scanned_count += 1
            self.observer.progress_at = float(self.env.now)

    def scanned_b64(self) -> str:
        bits = np.packbits(np.frombuffer(bytes(self.scanned), dtype=np.uint8), bitorder="little")
        return base64.b64encode(bits.tobytes()).decode("ascii")

    def picture(self) -> dict[str, Any]:
        """What a snapshot shows of the field: the sites, the minerals on the ground and the
        scanned cells (the engine's views and field mode's mission control both send it)."""
        return {
            "sites": [
                {
                    "id": s.id,
                    "x": s.x,
                    "y": s.y,
                    "found": s.found_at is not None,
                    "found_at": s.found_at,
                    "remaining": s.remaining,
                    "total": s.total,
                    "excavator": s.worker,
                }
                for s in self.sites
            ],
            "dropped": [{"x": g.x, "y": g.y} for g in self.ground],
            "scanned": self.scanned_b64(),
            "scanned_count": self.scanned_count,
            "cells_total": len(self.scanned),
        }

    def note_site_found(self, site: SiteState, by: str) -> None:
        if site.found_at is None:
            site.found_at = float(self.env.now)
            self.sites_found += 1
            self.observer.emit("site_found", site=site.id, by=by, x=site.x, y=site.y)
            self.check_finished()

    def note_delivery(self, by: str) -> None:
        self.delivered += 1
        self.observer.emit("delivered", robot=by, delivered=self.delivered)
        self.check_finished()

    def check_finished(self) -> None:
        if (
            self.sites_found == len(self.sites)
            and self.delivered == self.minerals_total
            and not self.finished.triggered
        ):
            self.finished_at = float(self.env.now)
            self.finished.succeed()
