"""The bidder role every capable robot plays (docs/spec.md §6.2–6.5): which open auctions to bid in
(the policy decides), the utility it bids, answering awards, and holding an accepted award
until the auctioneer's Close confirms it. Split from `base` so each file holds one concept."""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING, Any

import simpy

from engine.geometry import Point, path_length
from engine.messages import Ack, Award, Bid, TaskType
from engine.planning import PlanningError
from engine.policies import OpenAuction, PendingAward

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.robots.base import Assignment

REBID_S = 2.0
"""A time-bidding robot re-sends a bid when its estimate moved by more than this (seconds)."""


class Bidder:
    """Mixed into `Robot`; the names below are the robot's, declared for the type checker."""

    if TYPE_CHECKING:
        name: str
        rtype: str
        capability: TaskType | None
        partner: str | None
        pos: Point
        speed: float
        ctx: MissionContext
        env: simpy.Environment
        down: set[str]
        queue: deque[Assignment]
        current: Assignment | None
        reserved: OpenAuction | None
        open_auctions: dict[str, OpenAuction]
        rounds: dict[str, int]
        my_bids: dict[str, tuple[int, float]]
        pending_awards: list[PendingAward]
        _bid_situation: tuple[object, ...]

        @property
        def participating(self) -> bool: ...
        def auctions_in_order(self) -> list[OpenAuction]: ...
        def _spawn(self, gen: Any) -> None: ...
        def load(self) -> int: ...
        def position(self, t: float | None = None) -> tuple[Point, float]: ...

    def _on_award(self, msg: Award) -> None:
        if msg.winner != self.name:
            return
        info = self.open_auctions.get(msg.auction_id)
        bid = self.my_bids.get(msg.auction_id)
        if info is None or bid is None or not self.can_take():
            self._answer(msg.auction_id, msg.auctioneer, msg.location, False)
            return
        award = PendingAward(info, bid[1])
        if self.ctx.policy.collects_awards():
            self.pending_awards.append(award)
            if len(self.pending_awards) == 1:
                self._spawn(self._resolve_awards())
        else:
            self._accept(award)

    def _resolve_awards(self) -> Any:
        yield self.env.timeout(self.ctx.scenario.protocol.award_collect_s)
        awards, self.pending_awards = self.pending_awards, []
        if not awards:
            return
        best = self.ctx.policy.choose_award(awards) if self.can_take() else None
        for a in awards:
            if a is best:
                self._accept(a)
            else:
                self._answer(a.auction.auction_id, a.auction.auctioneer, a.auction.location, False)

    def _accept(self, award: PendingAward) -> None:
        a = award.auction
        self.reserved = a
        self._answer(a.auction_id, a.auctioneer, a.location, True)
        self._spawn(self._reservation_timer(a))

    def _answer(self, auction_id: str, auctioneer: str, location: Point, yes: bool) -> None:
        self.ctx.bus.publish(
            Ack(
                sender=self.name,
                auction_id=auction_id,
                auctioneer=auctioneer,
                winner=self.name,
                location=location,
                accepted=yes,
            )
        )

    def _reservation_timer(self, a: OpenAuction) -> Any:
        """An accepted award not confirmed by a Close in time is let go (the Close was lost)."""
        cfg = self.ctx.scenario
        wait = 2 * cfg.protocol.ack_timeout_s + 2 * (cfg.bus.latency_s + cfg.bus.jitter_s)
        try:
            yield self.env.timeout(wait)
        except simpy.Interrupt:
            return
        if self.reserved is a:
            self.reserved = None
            self.consider_bids()

    # --- bidding ------------------------------------------------------------------------
    def busy(self) -> bool:
        return self.reserved is not None or self.current is not None or bool(self.queue)

    def can_take(self) -> bool:
        return self.participating and self.has_room()

    def held(self) -> int:
        """Tasks won and not finished: the current one and the queue."""
        return (self.current is not None) + len(self.queue)

    def has_room(self) -> bool:
        """Free to win one more task: nothing reserved and no more held than the policy lets
        a robot queue (under Policies 1–3, exactly `not busy()`)."""
        return self.reserved is None and self.held() <= self.ctx.policy.queue_limit(self.rtype)

    def in_coalition(self) -> bool:
        """Paired with a live partner under a coalition policy (Policy 2)."""
        partner = self.partner
        return partner is not None and self.ctx.policy.coalitions() and self.peer_alive(partner)

    def peer_alive(self, name: str) -> bool:
        heard = self.ctx.liveness.last_heard(self.name, name)
        timeout = self.ctx.scenario.protocol.failure_timeout_s
        return name not in self.down and self.env.now - heard <= timeout

    def consider_bids(self) -> None:
        if not self.participating or self.capability is None:
            return
        auctions = self.auctions_in_order()
        if not auctions:
            return
        policy = self.ctx.policy
        targets = policy.bid_targets(self.rtype, self.in_coalition(), auctions)
        busy = not self.has_room()
        if policy.bids_time():
            self._bid_times(targets, busy)
            return
        every_round = self.ctx.scenario.protocol.busy_bid == "every_round"
        for a in targets:
            prev = self.my_bids.get(a.auction_id)
            rnd = self.rounds.get(a.auction_id, 0)
            if busy:
                # -inf tells the auctioneer "capable, but busy"; by default once per auction
                if prev is None or (every_round and prev[0] != rnd):
                    self._bid(a, rnd, -math.inf)
            elif prev is None or prev[0] != rnd or not math.isfinite(prev[1]):
                self._bid(a, rnd, -self.cost_to(a))

    def _bid_times(self, targets: list[OpenAuction], busy: bool) -> None:
        """Bids of a time-bidding policy: -(expected arrival time).

        Auctions (or rounds) I have not bid in get a bid. The others are looked at again only
        when my own situation changed (a task won or finished, a load, a stop): then a bid is
        re-sent if the estimate moved by more than `REBID_S`, and a robot that has run out of
        room withdraws its finite bids with -inf, so a winner is rarely one that must decline.
        A busy robot's -inf is sent once per auction, as under the other policies.
        """
        situation = (busy, self.current, len(self.queue), self.reserved, self.load(), self.pos)
        changed = situation != self._bid_situation
        self._bid_situation = situation
        every_round = self.ctx.scenario.protocol.busy_bid == "every_round"
        for a in targets:
            prev = self.my_bids.get(a.auction_id)
            rnd = self.rounds.get(a.auction_id, 0)
            fresh = prev is None or prev[0] != rnd
            if not (fresh or changed):
                continue
            if busy:
                if prev is None or math.isfinite(prev[1]) or (every_round and prev[0] != rnd):
                    self._bid(a, rnd, -math.inf)
                continue
            utility = -self.eta_to(a)
            if (
                prev is None
                or prev[0] != rnd
                or not math.isfinite(prev[1])
                or abs(prev[1] - utility) > REBID_S
            ):
                self._bid(a, rnd, utility)

    def eta_to(self, a: OpenAuction) -> float:
        """Seconds until this robot could stand at the task: finish what it holds, then drive."""
        wait, start = self.free_at()
        try:
            length = path_length(self.ctx.planner.plan(start, a.location))
        except PlanningError:
            return math.inf
        return wait + length / self.speed

    def free_at(self) -> tuple[float, Point]:
        """When (seconds from now) and where this robot will be free, from its own state."""
        return 0.0, self.position()[0]

    def cost_to(self, a: OpenAuction) -> float:
        """Length of the path this robot would drive to the task (docs/spec.md §6.2); inf if
        there is none."""
        try:
            return path_length(self.ctx.planner.plan(self.pos, a.location))
        except PlanningError:
            return math.inf

    def _bid(self, a: OpenAuction, rnd: int, utility: float) -> None:
        self.my_bids[a.auction_id] = (rnd, utility)
        self.ctx.bus.publish(
            Bid(
                sender=self.name,
                auction_id=a.auction_id,
                auctioneer=a.auctioneer,
                bidder=self.name,
                location=a.location,
                utility=utility,
                round=rnd,
            )
        )
