"""What one run shares: the clock, the bus, the planner, the physical world and the observer.

Robots reach each other only through the bus. The physical world (site piles, minerals on
the ground, who stands where) is shared because it is physical: a robot at a site sees the
pile and the robots beside it. The observer part (auction records, counters, the event log)
is bookkeeping for the researcher; no robot decision reads it.
"""

from __future__ import annotations

import base64
from collections.abc import Mapping, Set
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import simpy

from engine.auction_rules import AuctionRecord
from engine.events import Event, EventLog
from engine.geometry import Point, dist
from engine.liveness import Liveness
from engine.messages import Location, Message, TaskType
from engine.planning import PathPlanner
from engine.scenario import Protocol as ProtocolSettings
from engine.scenario import Scenario
from engine.world import World

if TYPE_CHECKING:
    from engine.bus import EmbeddedBus
    from engine.policies import Policy
    from engine.robots.base import Robot

NEAR = 0.5
"""Two points this close are the same place (a robot at a site, a mineral at a spot)."""

PROGRESS = frozenset(
    {"site_found", "dug", "pickup", "delivered", "mineral_recovered", "auction_closed"}
)
"""Events that move the mission forward; a long time with none of them (and no new cell
scanned, no operator action) is a stall."""


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


class MissionContext:
    def __init__(
        self,
        scenario: Scenario,
        world: World,
        planner: PathPlanner,
        env: simpy.Environment,
        policy: Policy,
    ) -> None:
        self.scenario = scenario
        self.world = world
        self.planner = planner
        self.env = env
        self.policy = policy
        self.log = EventLog(lambda: float(env.now))
        self.progress_at = 0.0
        self.log.subscribe(self._note_progress)
        self.bus: EmbeddedBus  # set by the mission once the bus exists
        self.liveness = Liveness()
        self.robots: dict[str, Robot] = {}
        self.sites = [SiteState(s.id, s.x, s.y, s.minerals, s.minerals) for s in world.sites]
        self.ground: list[GroundMineral] = []
        self.auctions: list[AuctionRecord] = []
        self.auctions_by_id: dict[str, AuctionRecord] = {}
        self._serial: dict[str, int] = {}
        self.delivered = 0
        self.minerals_total = sum(s.total for s in self.sites)
        self.sites_found = 0
        self.dropped = 0
        self.recovered = 0
        self.declines = 0
        self.failures = 0
        self.reauctions = 0
        self.bids = 0
        self.scanned = bytearray(world.grid.cols * world.grid.rows)
        self.scanned_count = 0
        self.scan_visits = 0
        self.finished = env.event()
        self.finished_at: float | None = None
        self.ground_serial = 0
        self._site_cells: dict[tuple[int, int], list[SiteState]] = {}
        g = world.grid
        for site in self.sites:
            key = (int(site.x // g.cell_w), int(site.y // g.cell_h))
            self._site_cells.setdefault(key, []).append(site)

    # --- what an auctioneer needs (engine.auction_house.AuctionPorts) ----------------------
    @property
    def protocol(self) -> ProtocolSettings:
        return self.scenario.protocol

    def publish(self, msg: Message) -> None:
        self.bus.publish(msg)

    def oracle_rank(
        self, rec: AuctionRecord, bids: Mapping[str, float], excluded: Set[str]
    ) -> list[str] | None:
        oracle = self.policy.allocator()
        return None if oracle is None else oracle.rank(self, rec, bids, excluded)

    # --- observer -------------------------------------------------------------------------
    def _note_progress(self, ev: Event) -> None:
        if ev.kind in PROGRESS:
            self.progress_at = ev.t

    def record_message(self, msg: Message) -> None:
        data = msg.to_dict()
        self.log.emit("message", **data)
        if data["type"] == "bid":
            self.bids += 1
            self.log.emit(
                "bid",
                auction_id=data["auction_id"],
                bidder=data["bidder"],
                utility=data["utility"],
                round=data["round"],
            )

    def new_auction(
        self,
        auctioneer: str,
        kind: str,
        task_type: TaskType,
        location: Location,
        task_id: str,
        search_path: tuple[Location, ...],
        reauction_of: str | None,
    ) -> AuctionRecord:
        n = self._serial.get(auctioneer, 0) + 1
        self._serial[auctioneer] = n
        rec = AuctionRecord(
            id=f"{auctioneer}/{n}",
            kind=kind,
            auctioneer=auctioneer,
            task_type=task_type,
            location=location,
            task_id=task_id,
            opened_at=float(self.env.now),
            policy=self.policy.name,
            reauction_of=reauction_of,
            search_path=search_path,
        )
        self.auctions.append(rec)
        self.auctions_by_id[rec.id] = rec
        if reauction_of is not None:
            self.reauctions += 1
            old = self.auctions_by_id.get(reauction_of)
            if old is not None and old.status == "open":
                self.close_auction(old, "superseded", None)
        self.log.emit(
            "auction_opened",
            auction_id=rec.id,
            kind=kind,
            auctioneer=auctioneer,
            task_type=task_type,
            task_id=task_id,
            location=list(location),
            reauction_of=reauction_of,
        )
        return rec

    def close_auction(self, rec: AuctionRecord, status: str, winner: str | None) -> None:
        for award in rec.awards:
            if award.outcome == "pending":  # cancelled or superseded while the winner pondered
                award.outcome = "withdrawn"
        rec.status = status
        rec.closed_at = float(self.env.now)
        rec.allocated_to = winner
        kind = "auction_closed" if status == "closed" else f"auction_{status}"
        self.log.emit(kind, auction_id=rec.id, allocated_to=winner, open_s=rec.open_time)

    def note_decline(self, rec: AuctionRecord, winner: str, outcome: str) -> None:
        self.declines += 1
        self.log.emit("auction_declined", auction_id=rec.id, bidder=winner, outcome=outcome)

    # --- physical world --------------------------------------------------------------------
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
        self.dropped += 1
        self.log.emit("mineral_dropped", robot=by, x=p[0], y=p[1], mineral=g.id)

    def ground_near(self, p: Point, radius: float = NEAR) -> GroundMineral | None:
        for g in self.ground:
            if dist((g.x, g.y), p) <= radius:
                return g
        return None

    def pick_ground(self, g: GroundMineral, by: str) -> None:
        self.ground.remove(g)
        self.recovered += 1
        self.log.emit("mineral_recovered", robot=by, x=g.x, y=g.y, mineral=g.id)

    def mark_scanned(self, cell: int) -> None:
        self.scan_visits += 1
        if not self.scanned[cell]:
            self.scanned[cell] = 1
            self.scanned_count += 1
            self.progress_at = float(self.env.now)

    def scanned_b64(self) -> str:
        bits = np.packbits(np.frombuffer(bytes(self.scanned), dtype=np.uint8), bitorder="little")
        return base64.b64encode(bits.tobytes()).decode("ascii")

    def note_site_found(self, site: SiteState, by: str) -> None:
        if site.found_at is None:
            site.found_at = float(self.env.now)
            self.sites_found += 1
            self.log.emit("site_found", site=site.id, by=by, x=site.x, y=site.y)
            self.check_finished()

    def note_delivery(self, by: str) -> None:
        self.delivered += 1
        self.log.emit("delivered", robot=by, delivered=self.delivered)
        self.check_finished()

    def check_finished(self) -> None:
        if (
            self.sites_found == len(self.sites)
            and self.delivered == self.minerals_total
            and not self.finished.triggered
        ):
            self.finished_at = float(self.env.now)
            self.finished.succeed()

    def minerals_in(self) -> dict[str, int]:
        """Where every mineral is now; the sum is always the total (conservation)."""
        buckets = sum(getattr(r, "bucket", 0) for r in self.robots.values())
        bins = sum(getattr(r, "bin", 0) for r in self.robots.values())
        return {
            "sites": sum(s.remaining for s in self.sites),
            "buckets": buckets,
            "bins": bins,
            "ground": len(self.ground),
            "delivered": self.delivered,
        }

    def emit(self, kind: str, /, **data: Any) -> None:
        self.log.emit(kind, **data)
