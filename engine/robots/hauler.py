"""Haulers carry one mineral at a time from a site (or the ground) to the plant."""

from __future__ import annotations

from typing import Any

from engine.geometry import Point, dist, path_length, segment_point_distance
from engine.messages import Close, TaskDone
from engine.policies import coalition_partner
from engine.robots.base import Robot
from engine.robots.bidder import Bidder
from engine.robots.core import Assignment
from engine.robots.handover import Taking
from engine.robots.partnership import Partnership
from engine.robots.rendezvous import (
    Arrived,
    Handover,
    Left,
    LocalRendezvous,
    Rendezvous,
    Sight,
    Witness,
)
from engine.terrain import NEAR

SENSE = 2.0
"""How far a hauler sees a mineral lying on the ground while it drives."""


class Hauler(Robot):
    rtype = "hauler"
    capability = "transport"
    hears = frozenset({"transport"})  # it never auctions, and sites are not its business

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.bidder = Bidder(self)
        self.bin = 0
        self.taking = Taking(self)  # my side of a hand-over
        self.rendezvous: Rendezvous = LocalRendezvous(self.ctx.robots)  # (field: its agent's)
        self.partnership = Partnership(self)  # Policy 2's partner excavator
        self._carrier: str | None = None  # an unpaired live hauler, last I looked (`stranded`)

    def load(self) -> int:
        return self.bin

    def work(self, a: Assignment) -> Any:
        yield from self.transport(a)

    def when_free(self) -> Any:
        if self.partnership.following():
            site = self.partnership.site
            assert site is not None
            if self.charging is not None and not self.charging.allows("transport", site):
                return  # to the charger first (`Robot.life`)
            yield from self.follow_partner()
        else:
            yield from super().when_free()

    # --- auctioned transport ------------------------------------------------------------
    def transport(self, a: Assignment) -> Any:
        self.state = "travelling"
        yield from self.mobility.go_to(a.location)
        exc = self._excavator_here(lambda e: e.expects(a.task_id))
        if exc is None and (self.ctx.policy.early_transports() or self.ctx.radio is not None):
            # (radio range: the excavator may have driven into reach to offer this transport)
            exc = yield from self.wait_for_excavator(a)
        if exc is not None and self.rendezvous.send(self, exc.name, Arrived(a.task_id)):
            yield from self.wait_loaded(exc.name, a.task_id)
        if not self.bin:
            yield from self.pick_from_ground(self.pos)
        route = a.search_path
        if not route and not self.bin and self._excavator_here(lambda e: True) is None:
            # nothing here and no excavator: another hauler may have taken this mineral and
            # fallen with it on the road, leaving its own unclaimed (attrition seed 179: a
            # search for a lost load found a fallen excavator's bucket at the pick-up point
            # first; the bucket's transport then came up empty and the load lay on the road)
            route = self.ctx.road_to_plant(a.location)
        if not self.bin and route:
            yield from self.search_along(route)
            yield from self.pick_from_ground(self.pos)
        if not self.bin:
            self.finish(a, "void")
            return
        yield from self.deliver()
        self.finish(a)

    def wait_for_excavator(self, a: Assignment) -> Any:
        """Came for a transport auctioned ahead and the excavator is not here yet: wait for it
        as long as it could take to drive here from where I last heard of it (and a margin)."""
        cfg = self.ctx.scenario
        hb = self.ctx.liveness.last_heartbeat(self.name, a.auctioneer)
        if hb is None or hb.rtype != "excavator":
            return None
        drive_s = dist((hb.x, hb.y), a.location) / cfg.speeds.excavator
        deadline = hb.t + drive_s + cfg.protocol.failure_timeout_s
        self.state = "waiting"
        while self.env.now < deadline and self.recovery.peer_alive(a.auctioneer):
            exc = self._excavator_here(lambda e: e.expects(a.task_id))
            if exc is not None:
                return exc
            if self._excavator_here(lambda e: e.name == a.auctioneer) is not None:
                return None  # it is here and does not expect me: nothing to carry
            left = deadline - self.env.now
            yield self.wait_for_wake() | self.env.timeout(min(left, cfg.protocol.heartbeat_s))
        return None

    def wait_loaded(self, exc: str, task_id: str) -> Any:
        """Stand by the excavator until it has emptied its bucket into my bin (longer if I came
        early for a mineral it is still digging, as long as it still expects me)."""
        self.state = "waiting"
        loaded = self.taking.wait()
        limit = self.ctx.scenario.timing.transfer_s + self.ctx.scenario.protocol.failure_timeout_s
        yield loaded | self.env.timeout(limit)
        while not loaded.triggered and self._still_expected(exc, task_id):
            yield loaded | self.env.timeout(limit)
        self.taking.stop()

    def _still_expected(self, exc: str, task_id: str) -> bool:
        seen = self.rendezvous.look(exc)
        return seen is not None and seen.alive and task_id in seen.ahead

    def on_handover(self, sender: Sight, msg: Handover, witness: Witness) -> bool:
        """An excavator beside me says something of the hand-over (`Taking`)."""
        return self.taking.on_handover(sender, msg, witness)

    def search_along(self, route: tuple[Point, ...]) -> Any:
        """Follow a failed robot's route until a fallen mineral comes into sight: the first one
        along the route. If another hauler took it before I got there, search on."""
        self.state = "travelling"
        for i in range(len(route) - 1):
            a, b = route[i], route[i + 1]
            seen = sorted(
                (dist(a, (g.x, g.y)), g.id, (g.x, g.y))
                for g in self.ctx.terrain.ground
                if segment_point_distance(a, b, (g.x, g.y)) <= SENSE
            )
            for _, _, spot in seen:
                yield from self.mobility.go_to(spot)
                if self.ctx.terrain.ground_near(self.pos, SENSE) is not None:
                    return
            yield from self.mobility.go_to(b)

    def pick_from_ground(self, p: Point) -> Any:
        g = self.ctx.terrain.ground_near(p, SENSE)
        if g is None:
            return
        if dist(p, (g.x, g.y)) > NEAR:
            yield from self.mobility.go_to((g.x, g.y))
        self.state = "loading"
        yield self.env.timeout(self.mobility.work_s(self.ctx.scenario.timing.transfer_s))
        if g in self.ctx.terrain.ground:
            self.bin = 1
            self.ctx.terrain.pick_ground(g, self.name)

    def deliver(self) -> Any:
        self.state = "carrying"
        yield from self.mobility.drive(
            self.ctx.planner.plan(self.pos, self.ctx.world.plant), report=True
        )
        unload_s = self.mobility.work_s(self.ctx.scenario.timing.unload_s)
        docks = self.ctx.docks
        if docks is None:
            self.state = "unloading"
            yield self.env.timeout(unload_s)
        else:
            yield from docks.unload(self, unload_s)
        self.bin = 0
        self.ctx.terrain.note_delivery(self.name)

    def _excavator_here(self, pred: Any) -> Sight | None:
        for seen in self.rendezvous.around(self.pos, "excavator"):
            if pred(seen):
                return seen
        return None

    def free_at(self) -> tuple[float, Point]:
        """Done with what it holds at the plant, after the current trip and every queued one
        (straight-line estimates for all but the bid's own leg)."""
        here = self.mobility.position()[0]
        if self.current is None and not self.queue:
            return 0.0, here
        timing, v, plant = self.ctx.scenario.timing, self.speed, self.ctx.world.plant
        t = 0.0
        cur = self.current
        if cur is not None:
            if self.bin:
                route = self.mobility.remaining_route()
                t += (path_length(route) if len(route) > 1 else dist(here, plant)) / v
            else:
                t += (dist(here, cur.location) + dist(cur.location, plant)) / v + timing.transfer_s
            t += timing.unload_s
        for a in self.queue:
            t += 2 * dist(plant, a.location) / v + timing.transfer_s + timing.unload_s
        if self.ctx.docks is not None:  # the queue it can see at the plant now
            t += self.ctx.docks.expected_wait_s(timing.unload_s)
        return t, plant

    # --- Policy 2: follow the partner excavator (`Partnership`) ---------------------------
    def follow_partner(self) -> Any:
        partnership = self.partnership
        site = partnership.site
        assert site is not None
        self.state = "travelling"
        yield from self.mobility.go_to(site)
        partner = self.partner
        if self.queue or not partnership.following():
            return  # won a task or was released while driving: back to the main loop
        exc = self._excavator_here(lambda e: e.name == partner)
        if exc is None:
            working = partnership.works_at()
            if working is not None and dist(working, site) > NEAR:
                partnership.site = working  # its heartbeat says it digs elsewhere: go there
                return
            if self.ctx.radio is not None and partnership.left_site():
                partnership.site = None  # (a TaskDone out of reach: its heartbeat tells)
                return
            # not there (yet, or any more): wait for news rather than spin
            self.state = "idle"
            yield self.wait_for_wake() | self.env.timeout(self.ctx.scenario.protocol.heartbeat_s)
            return
        self.state = "waiting"
        loaded = self.taking.wait()
        self.rendezvous.send(self, exc.name, Arrived(None))
        woken = self.wait_for_wake()
        yield loaded | woken
        loading_s = self.taking.loading_s
        if loading_s is not None:  # a transfer has begun: stay until it ends
            yield loaded | self.env.timeout(loading_s)
        self.taking.stop()
        self.rendezvous.send(self, exc.name, Left())
        if self.bin:
            yield from self.deliver()
            self.ctx.observer.emit("coalition_delivery", robot=self.name, excavator=exc.name)
            if self.current is not None:
                self.finish(self.current)

    def paired(self) -> bool:
        return self.partnership.paired()

    def partner_working(self) -> bool:
        return self.partnership.site is not None

    def transports_stranded(self) -> bool:
        """No unpaired hauler is alive to carry a transport (paired haulers take only their
        partner's minerals, and a partner never bids), as far as I know.

        A paired hauler asks it at every look: the last unpaired live hauler found is asked
        first, and most looks end there instead of going through every hauler (at scale 10
        this question was three quarters of a Policy 2 mission)."""
        carrier = self._carrier
        if carrier is not None and self._can_carry(carrier):
            return False
        for h in self.recovery.peers_of_type("hauler"):
            if h != self.name and self._can_carry(h):
                self._carrier = h
                return False  # an unpaired hauler is alive: it can carry
        self._carrier = None
        return True

    def _can_carry(self, hauler: str) -> bool:
        """Alive, and unpaired: its partner (if it has one) is not."""
        alive = self.recovery.peer_alive
        mate = coalition_partner(hauler)
        return alive(hauler) and not (mate and alive(mate))

    def on_close_heard(self, msg: Close) -> None:
        self.partnership.on_close(msg)

    def check_peers(self) -> None:
        super().check_peers()
        self.partnership.check()

    def on_task_done_heard(self, msg: TaskDone) -> None:
        self.partnership.on_task_done(msg)

    def on_revoked(self) -> None:
        self.taking.stop()
        super().on_revoked()

    def drop_loads(self) -> None:
        if self.bin:
            self.bin = 0
            self.ctx.terrain.drop_mineral(self.pos, self.name)
        self.taking.stop()
