"""Excavators dig a won site one bucket at a time and auction each mineral's transport."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import simpy

from engine.auction import Allocation
from engine.context import NEAR
from engine.geometry import Point, dist
from engine.messages import Close
from engine.robots.base import Assignment, Robot

if TYPE_CHECKING:
    from engine.context import SiteState
    from engine.robots.hauler import Hauler


class Excavator(Robot):
    rtype = "excavator"
    capability = "excavate"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.bucket = 0
        self.minerals_dug = 0
        self.waiting_for: str | None = None  # transport task id of the mineral in my bucket
        self._arrival: simpy.Event | None = None
        self.partner_here: Hauler | None = None
        self._ground_serial = 0

    def load(self) -> int:
        return self.bucket

    def life(self) -> Any:
        while True:
            if self.leaving:
                self.go_quiet()
                return
            if self.queue:
                a = self.queue.popleft()
                self.current = a
                yield from self.excavate(a)
            else:
                self.state = "idle"
                yield self.wait_for_wake()

    def excavate(self, a: Assignment) -> Any:
        self.state = "travelling"
        yield from self.go_to(a.location)
        site = self.ctx.site_at(a.location)
        self.auction_ground_minerals()
        if site is None or site.remaining == 0 or site.worker not in (None, self.name):
            self.finish(a, "void")  # nothing here, or another excavator is already digging
            return
        site.worker = site.last_worker = self.name
        try:
            while site.remaining > 0 and not self.leaving:
                self.state = "digging"
                yield self.env.timeout(self.ctx.scenario.timing.dig_s)
                site.remaining -= 1
                self.bucket = 1
                self.minerals_dug += 1
                self.ctx.emit("dug", robot=self.name, site=site.id, remaining=site.remaining)
                yield from self.hand_over(site)
        finally:
            if site.worker == self.name:
                site.worker = None
        self.finish(a, "done" if site.remaining == 0 else "released")

    def hand_over(self, site: SiteState) -> Any:
        """Empty the bucket into a hauler's bin: the waiting partner's, or an auction winner's.

        Looked at again whenever something changes (a hauler arrives, a heartbeat passes):
        a partner standing by takes the mineral unless an auction winner is already on its way.
        """
        task_id = f"{self.name}#m{self.minerals_dug}"
        self.waiting_for = task_id
        while self.bucket:
            on_its_way = task_id in self.house.allocations
            partner = self.partner_here
            if (
                not on_its_way
                and self.ctx.policy.coalitions()
                and partner is not None
                and partner.ready_for(self)
            ):
                self._cancel_transport(task_id)
                yield from self.transfer(partner, site)
                continue
            if not on_its_way and not self._transport_open(task_id):
                self.house.open("transport", (site.x, site.y), task_id, kind="excavator_hauler")
            self._arrival = arrival = self.env.event()
            self.state = "waiting"
            yield arrival | self.env.timeout(self.ctx.scenario.protocol.heartbeat_s)
            self._arrival = None
            if arrival.triggered:
                hauler = cast("Hauler", arrival.value)
                self._cancel_transport(task_id)
                yield from self.transfer(hauler, site)
        self.waiting_for = None

    def _transport_open(self, task_id: str) -> bool:
        return any(r.task_id == task_id for r in self.house.open_auctions.values())

    def _cancel_transport(self, task_id: str) -> None:
        for rec in list(self.house.open_auctions.values()):
            if rec.task_id == task_id:
                self.house.cancel(rec.id)  # the partner came back before anyone won it

    def transfer(self, hauler: Hauler, site: SiteState) -> Any:
        self.state = "loading"
        hauler.loading_from = self
        yield self.env.timeout(self.ctx.scenario.timing.transfer_s)
        hauler.loading_from = None
        if not hauler.can_receive(self):
            return  # it failed or left while we worked: the mineral is still in the bucket
        task_id = self.waiting_for
        assert task_id is not None
        self.bucket = 0
        if task_id not in self.house.allocations:
            # a coalition hand-over, outside any auction: watch its delivery all the same
            self.house.allocations[task_id] = Allocation(
                f"{self.name}/coalition",
                task_id,
                "transport",
                (site.x, site.y),
                hauler.name,
                float(self.env.now),
            )
        hauler.receive(self, task_id)
        self.ctx.emit(
            "pickup", robot=hauler.name, from_robot=self.name, x=self.pos[0], y=self.pos[1]
        )

    # --- physical rendezvous with haulers (they stand beside me) --------------------------
    def hauler_arrived(self, hauler: Hauler, task_id: str) -> bool:
        arrival = self._arrival
        ready = self.alive and self.bucket and self.waiting_for == task_id
        if ready and arrival is not None and not arrival.triggered:
            arrival.succeed(hauler)
            return True
        return False

    def partner_arrived(self, hauler: Hauler) -> None:
        self.partner_here = hauler
        rec_open = any(r.task_id == self.waiting_for for r in self.house.open_auctions.values())
        if self._arrival is not None and not self._arrival.triggered and rec_open:
            self._arrival.succeed(hauler)

    def partner_left(self, hauler: Hauler) -> None:
        if self.partner_here is hauler:
            self.partner_here = None

    def in_coalition(self) -> bool:
        return False  # excavators bid as Policy 1 under Policy 2

    def auction_ground_minerals(self) -> None:
        """Minerals lying where I stand (a failed robot's) get a transport, unless one is known."""
        here = self.pos
        for g in list(self.ctx.ground):
            if dist((g.x, g.y), here) > NEAR or self._transport_known_at((g.x, g.y)):
                continue
            self._ground_serial += 1
            self.house.open(
                "transport",
                (g.x, g.y),
                f"{self.name}#g{self._ground_serial}",
                kind="excavator_hauler",
            )

    def _transport_known_at(self, p: Point) -> bool:
        mine = [(r.task_type, r.location) for r in self.house.open_auctions.values()]
        mine += [(a.task_type, a.location) for a in self.house.allocations.values()]
        theirs = [(a.task_type, a.location) for d in self.peer_open.values() for a in d.values()]
        theirs += [(a.task_type, a.location) for d in self.peer_alloc.values() for a in d.values()]
        return any(t == "transport" and dist(loc, p) <= NEAR for t, loc in mine + theirs)

    def on_close_heard(self, msg: Close) -> None:
        pass

    def on_revoked(self) -> None:
        site = self.ctx.site_at(self.pos)
        if site is not None and site.worker == self.name:
            site.worker = None
        self.waiting_for = None
        self._arrival = None
        super().on_revoked()

    def drop_loads(self) -> None:
        if self.bucket:
            self.bucket = 0
            self.ctx.drop_mineral(self.pos, self.name)
        site = self.ctx.site_at(self.pos)
        if site is not None and site.worker == self.name:
            site.worker = None
        self.waiting_for = None
        self._arrival = None
