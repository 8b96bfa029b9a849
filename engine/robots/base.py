"""What every robot does: move, listen, bid, accept, keep its peers' liveness, fail and return.

A robot knows only what reached it on the bus and what it senses where it stands. Its
behaviour (scan, dig, haul) lives in a subclass as a simpy process; the protocol roles
(bidder here, auctioneer in `AuctionHouse`) are shared.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

import simpy

from engine.auction_rules import Allocation
from engine.field import NEAR
from engine.geometry import dist
from engine.messages import (
    Ack,
    Announce,
    Award,
    Bid,
    Close,
    Handoff,
    Hello,
    Holding,
    Leaving,
    Message,
    Probe,
    Revoke,
    Takeover,
    TaskDone,
)
from engine.planning import PlanningError
from engine.policies import OpenAuction
from engine.robots.charging import Charging
from engine.robots.core import Assignment
from engine.robots.recovery import Recovery

if TYPE_CHECKING:
    pass


class Robot(Charging, Recovery):
    """A robot: the core, the bidder, charging and recovery roles, message handling, and the
    life cycle of work, failure and return; scouts, excavators and haulers fill in `life` or
    `work`."""

    # --- lifecycle ----------------------------------------------------------------------
    def start(self, joined_late: bool = False) -> None:
        self._life_proc = self.env.process(self._life_guarded())
        self._procs.append(self._life_proc)
        self._spawn(self._tick())
        if joined_late:
            self.ctx.bus.publish(
                Hello(sender=self.name, rtype=self.rtype, wants_work=self.wants_work())
            )

    def wants_work(self) -> bool:
        """Hook: a scout with nothing to scan asks for a share of the search."""
        return False

    def _life_guarded(self) -> Any:
        while True:
            try:
                yield from self.life()
                return
            except simpy.Interrupt as irq:
                if irq.cause != "revoked" or not self.alive:
                    return
                self._end_motion()  # the task was taken back: stop and look again
                self.on_revoked()

    def life(self) -> Any:
        """Work through the tasks won, one at a time; between them, what a free robot does."""
        while True:
            if self.leaving:
                self.go_quiet()
                return
            if self.battery is not None and self.needs_charge():
                yield from self.recharge()
                continue
            if self.queue:
                self.current = self.queue.popleft()
                yield from self.work(self.current)
            else:
                yield from self.when_free()

    def work(self, a: Assignment) -> Any:
        """Carry out one won task; robots that win tasks override it."""
        raise NotImplementedError(f"{self.rtype} cannot carry out {a.task_type}")
        yield  # pragma: no cover - makes this a generator

    def when_free(self) -> Any:
        """Nothing to do: wait until something changes (where the policy says, if it does)."""
        radio = self.ctx.radio
        if radio is not None and not radio.in_contact(self.name):
            yield from self.regain_contact()
            return
        spot = self.ctx.policy.standby(self.ctx, self.name)
        if spot is None:
            self.state = "idle"
            yield self.wait_for_wake()
            return
        if self.battery is not None and not self.energy_for_trip(spot):
            return  # to the charger first (`life`)
        if dist(self.pos, spot) > NEAR:
            self.state = "travelling"
            try:
                yield from self.go_to(spot)
            except PlanningError:
                pass
            else:
                return
        # standing by: look again now and then, in case the plan changed
        self.state = "idle"
        yield self.wait_for_wake() | self.env.timeout(self.ctx.scenario.protocol.heartbeat_s)

    # --- energy (the rest is `Charging`) ----------------------------------------------------
    def run_dry(self) -> None:
        """The battery is empty: the robot stops where it is, a failure like any other."""
        obs = self.ctx.observer
        obs.failures += 1
        self.fail()
        obs.emit("robot_failed", robot=self.name, x=self.pos[0], y=self.pos[1], cause="energy")

    def regain_contact(self) -> Any:
        """Radio range: an idle robot out of the base station's reach drives back into it,
        where auctions can reach it (and its own be heard)."""
        radio = self.ctx.radio
        assert radio is not None
        spot = radio.contact_point(self.pos)
        if self.battery is not None and not self.energy_for_trip(spot):
            if self.rtype != "scout":
                return  # to the charger first (`life`): it is in reach anyway
            yield from self.recharge()
            return
        self.state = "travelling"
        try:
            yield from self.go_to(spot)
        except PlanningError:
            self.state = "idle"
            yield self.wait_for_wake() | self.env.timeout(self.ctx.scenario.protocol.heartbeat_s)

    def on_revoked(self) -> None:
        """Hook: tidy up after the current task was revoked mid-way."""
        self.current = None
        self.consider_bids()

    def _tick(self) -> Any:
        proto = self.ctx.scenario.protocol
        offset = (self.ctx.liveness.index[self.name] % 10) * proto.heartbeat_s / 10
        try:
            yield self.env.timeout(offset)
            while True:
                self.heartbeat()
                self.check_peers()
                yield self.env.timeout(proto.heartbeat_s)
        except simpy.Interrupt:
            return

    # --- messages -----------------------------------------------------------------------
    def on_message(self, msg: Message) -> None:
        if not self.alive:
            return
        handler = _HANDLERS.get(type(msg))
        if handler is not None:
            handler(self, msg)

    def _on_announce(self, msg: Announce) -> None:
        task_id, aid = msg.task_id, msg.auction_id
        if task_id in self.completed:
            # offered again from an old record (a watcher back from a failure that missed my
            # TaskDone): it is done, say so again and the auctioneer withdraws it
            self.ctx.bus.publish(
                TaskDone(
                    sender=self.name, auction_id=msg.auction_id, task_id=msg.task_id, outcome="done"
                )
            )
            return
        cur = self.current
        if (cur is not None and cur.task_id == task_id) or (
            self.queue and any(a.task_id == task_id for a in self.queue)
        ):
            self.ctx.bus.publish(
                Holding(sender=self.name, task_id=msg.task_id, auction_id=msg.auction_id)
            )
            return
        rounds = self.rounds
        if aid in rounds:  # a re-announcement: only the round is new
            rounds[aid] = msg.round
            if aid in self.open_auctions:
                self.consider_bids()
            return
        self.rounds[msg.auction_id] = msg.round
        info = OpenAuction(
            msg.auction_id,
            msg.auctioneer,
            msg.task_type,
            msg.location,
            msg.task_id,
            msg.opened_at,
            msg.search_path,
        )
        if self.peer_type(msg.sender) == self.rtype:
            self.peer_open.setdefault(msg.sender, {})[msg.auction_id] = info
        # a duplicate auction for a task I am auctioning: the smaller name keeps it
        self.house.yield_duplicate(msg.auction_id, msg.task_id, msg.sender)
        self.on_task_heard(info)
        if msg.task_type == self.capability:
            self.note_auction(info)
            self.consider_bids()

    def on_task_heard(self, info: OpenAuction) -> None:
        """Hook: any announcement (scouts learn of sites their peers found)."""

    def _on_bid(self, msg: Bid) -> None:
        if msg.auctioneer == self.name:
            self.house.on_bid(msg)

    def _on_ack(self, msg: Ack) -> None:
        if msg.auctioneer == self.name:
            self.house.on_ack(msg)

    def _on_close(self, msg: Close) -> None:
        info = self.forget_auction(msg.auction_id)
        if self.my_bids.pop(msg.auction_id, None) is not None:
            self._refused = None
            self._quiet_on = None
        peer = self.peer_open.get(msg.sender)
        if peer is not None:
            peer.pop(msg.auction_id, None)
            if msg.allocated_to is not None:
                self.note_peer_alloc(
                    msg.sender,
                    Allocation(
                        msg.auction_id,
                        msg.task_id,
                        msg.task_type,
                        msg.location,
                        msg.allocated_to,
                        float(self.env.now),
                    ),
                )
        self.on_close_heard(msg)
        if self.reserved is not None and self.reserved.auction_id == msg.auction_id:
            reserved, self.reserved = self.reserved, None
            if msg.allocated_to == self.name and self.alive:
                self.assign(
                    Assignment(
                        reserved.auction_id,
                        reserved.auctioneer,
                        reserved.task_type,
                        reserved.task_id,
                        reserved.location,
                        reserved.search_path,
                    )
                )
        elif info is not None or msg.allocated_to is not None:
            self.consider_bids()

    def on_close_heard(self, msg: Close) -> None:
        """Hook: subclasses track what others were allocated (coalition partners)."""

    def _on_task_done(self, msg: TaskDone) -> None:
        # only the robot a task was allocated to ends that allocation (a duplicate holder's
        # "void" must not end the real holder's watch)
        self.end_peer_alloc(msg.task_id, msg.sender)
        self.house.task_done(msg)
        self.on_task_done_heard(msg)

    def on_task_done_heard(self, msg: TaskDone) -> None:
        """Hook for subclasses."""

    def _on_hello(self, msg: Hello) -> None:
        self.peers[msg.sender] = msg.rtype
        self.house.reannounce_open()
        self.return_duties(msg.sender)
        self.on_hello_heard(msg)

    def on_hello_heard(self, msg: Hello) -> None:
        """Hook: scouts share their remaining cells with a newcomer."""

    def on_handoff_heard(self, msg: Handoff) -> None:
        """Hook: scouts track who scans which cells."""

    # --- tasks --------------------------------------------------------------------------
    def assign(self, a: Assignment) -> None:
        self.queue.append(a)
        self.ctx.observer.emit(
            "task_started",
            robot=self.name,
            task_id=a.task_id,
            task_type=a.task_type,
            auction_id=a.auction_id,
        )
        self.wake()

    def finish(self, a: Assignment, outcome: Literal["done", "void", "released"] = "done") -> None:
        self.current = None
        if outcome != "released":  # a released task is not done: its watcher offers it again
            self.done_ids.append(a.task_id)
        if outcome == "done" or (outcome == "void" and a.task_type == "transport"):
            self.completed.add(a.task_id)  # final: no one need ever carry this again
        self.ctx.observer.emit("task_ended", robot=self.name, task_id=a.task_id, outcome=outcome)
        self.ctx.bus.publish(
            TaskDone(sender=self.name, auction_id=a.auction_id, task_id=a.task_id, outcome=outcome)
        )
        self.consider_bids()

    # --- operator-driven failures -------------------------------------------------------
    def fail(self) -> None:
        """Abrupt failure: stop where it is; nothing is sent or answered any more."""
        self._end_motion()
        self.alive = False
        self.enabled = False
        self.state = "failed"
        me = self.env.active_process  # a graceful exit runs inside the robot's own process
        for p in self._procs:
            if p.is_alive and p is not me:
                p.interrupt("failed")
        self._procs.clear()
        self.dormant = self.dormant.merge(self.house.stop())
        self.drop_loads()
        self.current = None
        self.queue.clear()

    def drop_loads(self) -> None:
        """Hook: whatever it carries falls where it stands."""

    def disable(self) -> None:
        """Graceful: take nothing new, finish the current hand-over, then say goodbye."""
        self.leaving = True
        self.wake()

    def go_quiet(self) -> None:
        """The end of a graceful disable: announce it, then stop like a failure. Its open
        auctions stay open for the peer that adopts them (cancelling would lose their tasks)."""
        self.ctx.bus.publish(Leaving(sender=self.name, progress=self.progress()))
        self.fail()
        self.state = "disabled"
        self.ctx.observer.emit("robot_quiet", robot=self.name)

    def enable(self) -> None:
        """Back from a failure (a new life): a full peer at once for bidding and working; its
        earlier duties are settled after a listening period (`Recovery.rejoin`)."""
        self.alive = True
        self.enabled = True
        self.leaving = False
        if self.battery is not None:  # the operator's rescue brings it back charged
            self.battery.settle(float(self.env.now))
            self.battery.level = self.battery.capacity
            self.battery.must_charge = False
        self.state = "idle"
        self.current = None
        self.queue.clear()
        self._reset_knowledge()
        self.house = self._new_house()
        self.rejoining = True
        self.taken_back = set()
        self.start(joined_late=True)
        self._spawn(self.rejoin())


_HANDLERS: dict[type[Message], Any] = {
    Announce: Robot._on_announce,
    Bid: Robot._on_bid,
    Award: Robot._on_award,
    Ack: Robot._on_ack,
    Close: Robot._on_close,
    TaskDone: Robot._on_task_done,
    Holding: Robot._on_holding,
    Takeover: Robot._on_takeover,
    Leaving: Robot._on_leaving,
    Hello: Robot._on_hello,
    Handoff: lambda robot, msg: robot.on_handoff_heard(msg),
    Probe: Robot._on_probe,
    Revoke: Robot._on_revoke,
}
