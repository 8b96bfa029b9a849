"""Excavators dig a won site one bucket at a time and auction each mineral's transport."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import simpy

from engine.auction_rules import Allocation
from engine.geometry import Point, dist
from engine.robots.base import Robot
from engine.robots.bidder import Bidder
from engine.robots.core import Assignment
from engine.robots.rendezvous import (
    Arrived,
    Handover,
    Here,
    Left,
    Loading,
    LocalRendezvous,
    Ready,
    Rendezvous,
    Sight,
    Transfer,
    Witness,
)
from engine.robots.transport import Transports
from engine.terrain import NEAR

if TYPE_CHECKING:
    from engine.terrain import SiteState


def transports_due(
    pile: int, opened: int, dig_s: float, transfer_s: float, lead_s: float
) -> tuple[int, float | None]:
    """At the start of a dig: how many more transports to auction now, and after how many
    seconds of this dig one more falls due (None: none does).

    `pile` minerals are left, counting the one being dug; `opened` of them already have their
    transport. Mineral j (0 = this one) is expected to fill its bucket after dig_s + j·(dig_s +
    transfer_s) seconds and its transport is due `lead_s` before that.
    """
    cycle = dig_s + transfer_s
    j = opened
    while j < pile and dig_s + j * cycle - lead_s <= 0.0:
        j += 1
    due = dig_s + j * cycle - lead_s
    return j - opened, (due if j < pile and due < dig_s else None)


class Excavator(Robot):
    rtype = "excavator"
    capability = "excavate"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.bidder = Bidder(self)
        self.bucket = 0
        self.minerals_dug = 0
        self.waiting_for: str | None = None  # transport task id of the mineral in my bucket
        self._arrival: simpy.Event | None = None
        self.partner_here: str | None = None  # my coalition partner, standing by
        # transports auctioned ahead of their minerals (a lead policy), next mineral first
        self.ahead: list[str] = []
        self.early: dict[str, str] = {}  # haulers that came for one of them and stand by
        self.rendezvous: Rendezvous = LocalRendezvous(self.ctx.robots)  # (field: its agent's)
        self.transfer_now_s = self.ctx.scenario.timing.transfer_s  # the transfer under way
        self.transports = Transports(self)

    def load(self) -> int:
        return self.bucket

    def work(self, a: Assignment) -> Any:
        yield from self.excavate(a)

    def excavate(self, a: Assignment) -> Any:
        self.state = "travelling"
        self.transports.auction_on_the_way(a)
        yield from self.mobility.go_to(a.location)
        site = self.ctx.terrain.site_at(a.location)
        if self.ahead:
            for h in self.rendezvous.around(self.pos, "hauler", living=False):
                self.rendezvous.send(self, h.name, Here())  # one that came ahead of me
        self.transports.auction_ground_minerals()
        if site is None or site.remaining == 0 or site.worker not in (None, self.name):
            self.transports.drop_ahead(self.early)
            self.finish(a, "void")  # nothing here, or another excavator is already digging
            return
        site.worker = site.last_worker = self.name
        try:
            while (
                site.remaining > 0
                and not self.leaving
                and (self.charging is None or self.charging.bucket_allowed((site.x, site.y)))
            ):
                self.state = "digging"
                yield from self.dig(site)
                site.remaining -= 1
                self.bucket = 1
                self.minerals_dug += 1
                self.ctx.observer.emit(
                    "dug", robot=self.name, site=site.id, remaining=site.remaining
                )
                if self.ahead and not self.ctx.policy.early_transports():
                    self.transports.drop_ahead(
                        self.early
                    )  # the policy changed: no more transports ahead
                if self.ahead:
                    yield from self.hand_over_ahead(site)
                else:
                    yield from self.hand_over(site)
        finally:
            if site.worker == self.name:
                site.worker = None
            self.transports.drop_ahead(self.early)
        self.finish(a, "done" if site.remaining == 0 else "released")

    def dig(self, site: SiteState) -> Any:
        """Dig one bucket. Under a policy with a transport lead L, the transport of every mineral
        of the pile is auctioned L seconds before its bucket is expected to fill (one dig plus
        one transfer per mineral, from now), so its hauler arrives about when it does."""
        cfg = self.ctx.scenario
        dig_s = cfg.timing.dig_s
        haul_s = dist((site.x, site.y), self.ctx.world.plant) / cfg.speeds.hauler
        lead = self.ctx.policy.transport_lead_s(haul_s, dig_s)
        took = self.mobility.work_s(
            dig_s
        )  # the lead is planned on the mean dig; this one may differ
        if lead <= 0.0:
            yield self.env.timeout(took)
            return
        now, later = transports_due(
            site.remaining, len(self.ahead), dig_s, cfg.timing.transfer_s, lead
        )
        for _ in range(now):
            self.transports.auction_ahead(site)
        if later is None:
            yield self.env.timeout(took)
        else:
            first = min(later, took)
            yield self.env.timeout(first)
            self.transports.auction_ahead(site)
            yield self.env.timeout(took - first)

    def hand_over_ahead(self, site: SiteState) -> Any:
        """Empty the bucket into the bin of any hauler standing by for one of my transports
        (the earliest such transport takes this mineral); wait if none is here yet."""
        while self.bucket:
            if not self.ahead:
                self.transports.auction_ahead(site)  # more in the pile than expected: one more now
            for i, task_id in enumerate(self.ahead):
                if not self.house.handles(task_id):
                    # it ended without this pile's mineral (void, lost, or its hauler carried
                    # another): a new transport, under a new id (the old one is over for good)
                    self.ahead[i] = self.transports.new_id("t")
                    self.house.open(
                        "transport", (site.x, site.y), self.ahead[i], kind="excavator_hauler"
                    )
            ready = [
                t
                for t in self.ahead
                if t in self.early and self.rendezvous.send(self, self.early[t], Ready(free=False))
            ]
            if ready:
                task_id = ready[0]
                hauler = self.early.pop(task_id)
                self.waiting_for = task_id
                yield from self.transfer(hauler, site)
                if not self.bucket:
                    self.ahead.remove(task_id)
                self.waiting_for = None
                continue
            if self.ctx.radio is not None and self.transports.unheard(self.ahead[0]):
                yield from self.transports.report_in(site, self.ahead[0])
                continue
            self._arrival = arrival = self.env.event()
            self.state = "waiting"
            yield arrival | self.env.timeout(self.ctx.scenario.protocol.heartbeat_s)
            self._arrival = None

    def hand_over(self, site: SiteState) -> Any:
        """Empty the bucket into a hauler's bin: the waiting partner's, or an auction winner's.

        Looked at again whenever something changes (a hauler arrives, a heartbeat passes):
        a partner standing by takes the mineral unless an auction winner is already on its way.
        """
        task_id = self.ctx.observer.of_this_life(f"{self.name}#m{self.minerals_dug}")
        self.waiting_for = task_id
        offered = False
        while self.bucket:
            on_its_way = task_id in self.house.watches
            partner = self.partner_here
            if (
                not on_its_way
                and self.ctx.policy.coalitions()
                and partner is not None
                and self.rendezvous.send(self, partner, Ready(free=True))
            ):
                self.house.cancel_task(task_id)
                yield from self.transfer(partner, site)
                continue
            if not on_its_way and not self.house.is_open(task_id):
                if offered:  # the last one ended without this mineral: a new one, a new id
                    task_id = self.waiting_for = self.transports.new_id("r")
                self.house.open("transport", (site.x, site.y), task_id, kind="excavator_hauler")
                offered = True
            if self.ctx.radio is not None and self.transports.unheard(task_id):
                yield from self.transports.report_in(site, task_id)
                continue
            self._arrival = arrival = self.env.event()
            self.state = "waiting"
            yield arrival | self.env.timeout(self.ctx.scenario.protocol.heartbeat_s)
            self._arrival = None
            if arrival.triggered:
                hauler = str(arrival.value)
                if self.house.watches.winner_of(task_id) not in (None, hauler):
                    continue  # my partner came as the auction closed: its winner is on its way
                self.house.cancel_task(task_id)
                yield from self.transfer(hauler, site)
        self.waiting_for = None

    def transfer(self, hauler: str, site: SiteState) -> Any:
        """Empty the bucket into the bin of the hauler beside me: it takes the mineral on the
        `Transfer` at the end, or refuses it (it failed or left meanwhile: it stays here)."""
        self.state = "loading"
        self.transfer_now_s = self.mobility.work_s(self.ctx.scenario.timing.transfer_s)
        self.rendezvous.send(self, hauler, Loading(self.transfer_now_s))
        yield self.env.timeout(self.transfer_now_s)
        task_id = self.waiting_for
        assert task_id is not None
        if not self.rendezvous.send(self, hauler, Transfer(task_id)):
            return
        self.bucket = 0
        if task_id not in self.house.watches:
            # a coalition hand-over, outside any auction: watch its delivery all the same
            self.house.watches.add(
                Allocation(
                    f"{self.name}/coalition",
                    task_id,
                    "transport",
                    (site.x, site.y),
                    hauler,
                    float(self.env.now),
                )
            )
        self.ctx.observer.emit(
            "pickup", robot=hauler, from_robot=self.name, x=self.pos[0], y=self.pos[1]
        )

    def free_at(self) -> tuple[float, Point]:
        """Done with the site it works (the pile it sees, or an average one it has not seen
        yet) and every queued site."""
        here = self.mobility.position()[0]
        if self.current is None and not self.queue:
            return 0.0, here
        cfg, v = self.ctx.scenario, self.speed
        per = cfg.timing.dig_s + cfg.timing.transfer_s
        unseen = cfg.minerals / cfg.sites * per
        t, pos = 0.0, here
        cur = self.current
        if cur is not None:
            site = self.ctx.terrain.site_at(self.pos) if self.motion is None else None
            if site is not None and dist(self.pos, cur.location) <= NEAR:
                t += site.remaining * per + (cfg.timing.transfer_s if self.bucket else 0.0)
            else:
                t += dist(here, cur.location) / v + unseen
            pos = cur.location
        for a in self.queue:
            t += dist(pos, a.location) / v + unseen
            pos = a.location
        return t, pos

    # --- physical rendezvous with haulers (they stand beside me) --------------------------
    def on_handover(self, sender: Sight, msg: Handover, _witness: Witness) -> bool:
        """A hauler beside me says something of a hand-over (`engine.robots.rendezvous`)."""
        if isinstance(msg, Arrived):
            if msg.task_id is None:
                self._partner_arrived(sender.name)
                return True
            return self._hauler_arrived(sender.name, msg.task_id)
        if isinstance(msg, Left):
            if self.partner_here == sender.name:
                self.partner_here = None
            return True
        return False  # (a giver's own messages are not for it)

    def _hauler_arrived(self, hauler: str, task_id: str) -> bool:
        arrival = self._arrival
        ready = self.alive and self.bucket and self.waiting_for == task_id
        if ready and arrival is not None and not arrival.triggered:
            arrival.succeed(hauler)
            return True
        if self.alive and task_id in self.ahead:
            self.early[task_id] = hauler  # it stands by for its mineral
            if arrival is not None and not arrival.triggered:
                arrival.succeed(hauler)
            return True
        return False

    def _partner_arrived(self, hauler: str) -> None:
        self.partner_here = hauler
        waiting_for = self.waiting_for
        rec_open = waiting_for is not None and self.house.is_open(waiting_for)
        if self._arrival is not None and not self._arrival.triggered and rec_open:
            self._arrival.succeed(hauler)

    def paired(self) -> bool:
        return False  # excavators bid as Policy 1 under Policy 2

    def partner_working(self) -> bool:
        return False

    def transports_stranded(self) -> bool:
        return False

    def when_free(self) -> Any:
        """Idle: a mineral lying where I stand (my own bucket's, if I failed here) gets a
        transport like any I find on arrival."""
        self.transports.auction_ground_minerals()
        yield from super().when_free()

    def on_rejoined(self) -> None:
        self.transports.auction_ground_minerals()

    def on_revoked(self) -> None:
        site = self.ctx.terrain.site_at(self.pos)
        if site is not None and site.worker == self.name:
            site.worker = None
        self.waiting_for = None
        self._arrival = None
        self.transports.drop_ahead(self.early)
        super().on_revoked()

    def drop_loads(self) -> None:
        if self.bucket:
            self.bucket = 0
            self.ctx.terrain.drop_mineral(self.pos, self.name)
        site = self.ctx.terrain.site_at(self.pos)
        if site is not None and site.worker == self.name:
            site.worker = None
        self.waiting_for = None
        self._arrival = None
        self.ahead.clear()
        self.early.clear()
