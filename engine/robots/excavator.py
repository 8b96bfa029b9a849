"""Excavators dig a won site one bucket at a time and auction each mineral's transport."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import simpy

from engine.messages import Close
from engine.policies import coalition_partner
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
        """Empty the bucket into a hauler's bin: the waiting partner's, or an auction winner's."""
        partner = self.partner_here
        if self.ctx.policy.coalitions() and partner is not None and partner.ready_for(self):
            yield from self.transfer(partner)
            return
        task_id = f"{self.name}#m{self.minerals_dug}"
        rec = self.house.open("transport", (site.x, site.y), task_id, kind="excavator_hauler")
        self.waiting_for = task_id
        while self.bucket:
            self._arrival = self.env.event()
            self.state = "waiting"
            hauler: Hauler = yield self._arrival
            self._arrival = None
            if rec.id in self.house.open_auctions:
                self.house.cancel(rec.id)  # the partner came back before anyone won it
            yield from self.transfer(hauler)
        self.waiting_for = None

    def transfer(self, hauler: Hauler) -> Any:
        self.state = "loading"
        yield self.env.timeout(self.ctx.scenario.timing.transfer_s)
        if not hauler.alive:
            return  # it failed while we worked; the mineral is still in the bucket
        self.bucket = 0
        hauler.receive(self)
        self.ctx.emit(
            "pickup", robot=hauler.name, from_robot=self.name, x=self.pos[0], y=self.pos[1]
        )

    # --- physical rendezvous with haulers (they stand beside me) --------------------------
    def hauler_arrived(self, hauler: Hauler, task_id: str) -> bool:
        if self.alive and self.bucket and self.waiting_for == task_id and self._arrival is not None:
            if not self._arrival.triggered:
                self._arrival.succeed(hauler)
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

    def on_close_heard(self, msg: Close) -> None:
        pass

    def drop_loads(self) -> None:
        if self.bucket:
            self.bucket = 0
            self.ctx.drop_mineral(self.pos, self.name)
        site = self.ctx.site_at(self.pos)
        if site is not None and site.worker == self.name:
            site.worker = None
        self.waiting_for = None
        self._arrival = None

    def partner_name(self) -> str | None:
        return coalition_partner(self.name)
