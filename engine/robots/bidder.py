"""The bidder role every capable robot plays (docs/spec.md §6.2–6.5): which open auctions to bid in
(the policy decides), the utility it bids, answering awards, and holding an accepted award
until the auctioneer's Close confirms it. Split from `base` so each file holds one concept."""

from __future__ import annotations

import math
from typing import Any

import simpy

from engine.bidding import BidMemory, Bids, refused_all
from engine.geometry import Point, path_length
from engine.messages import Ack, Award, Bid
from engine.planning import PlanningError
from engine.policies import OpenAuction, PendingAward, Policy
from engine.robots.core import RobotCore


class Bidder(RobotCore):
    """The bidder role of a robot."""

    def _on_award(self, msg: Award) -> None:
        if msg.winner != self.name:
            return
        info = self.open_auctions.get(msg.auction_id)
        bid = self.my_bids.get(msg.auction_id)
        if (
            info is None
            or bid is None
            or not self.can_take()
            or not self.energy_allows(info.task_type, info.location)
        ):
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
        return (
            self.reserved is None
            and self.held() <= self.ctx.policy.queue_limit(self.rtype)
            and (self.battery is None or not self.battery.must_charge)
        )

    def paired(self) -> bool:
        """Paired with a live partner under a coalition policy (Policy 2)."""
        partner = self.partner
        return partner is not None and self.ctx.policy.coalitions() and self.peer_alive(partner)

    def partner_working(self) -> bool:
        return False

    def stranded(self, a: OpenAuction) -> bool:
        return False

    def policy_changed(self) -> None:
        """A new policy may bid in other units or by other rules: look at everything afresh."""
        self._bid_situation = ()
        self.consider_bids()

    def consider_bids(self) -> None:
        """Send the bids my policy asks for, given what I know (`engine/bidding.py`)."""
        if not self.participating or self.capability is None:
            return
        auctions = self.auctions_in_order()
        if not auctions:
            return
        policy = self.ctx.policy
        busy = not self.has_room()
        every_round = self._every_round
        quiet = busy and not every_round
        if quiet and self._quiet_on is auctions and self._quiet_policy is policy:
            return  # busy, and nothing I bid from changed since I last had nothing to send
        situation = (busy, self.current, len(self.queue), self.reserved, self.load(), self.pos)
        if quiet and policy.targets_pure and self._refused_all():
            # no room, and -inf said in every auction I know: no bid, whatever the targets
            self._bid_situation = situation
            self._note_quiet(auctions, policy)
            return
        targets = policy.bid_targets(self, auctions)
        if quiet and refused_all(self.my_bids, targets):
            self._bid_situation = situation
            self._note_quiet(auctions, policy)
            return
        mem = BidMemory(
            busy=busy,
            sent=self.my_bids,
            rounds=self.rounds,
            changed=situation != self._bid_situation,
            every_round=every_round,
        )
        self._bid_situation = situation
        bids = policy.bids(self, targets, mem)
        if self.battery is not None:
            bids = self._within_reach(bids)
        for a, rnd, utility in bids:
            self._bid(a, rnd, utility)

    def _note_quiet(self, auctions: list[OpenAuction], policy: Policy) -> None:
        """Remember that, busy, I had nothing to send for this list (an object never changed
        in place) and my bids as they are: under a policy whose targets come from the list
        alone, asking again before either changes gives the same nothing."""
        if policy.targets_from_list:
            self._quiet_on, self._quiet_policy = auctions, policy

    def _refused_all(self) -> bool:
        """Have I bid -inf in every open auction I can serve? Cached until an auction comes or
        goes or I bid (`_refused` is updated or reset wherever `_in_order` or `my_bids` changes)."""
        if self._refused is None:
            sent = self.my_bids
            self._refused = refused_all(sent, self.auctions_in_order())
        return self._refused

    def _within_reach(self, bids: Bids) -> Bids:
        """Energy: a task I could not finish and still reach a charger gets -inf, and then I
        go to charge (so does every other bid of this look: I am busy charging)."""
        if all(
            not math.isfinite(u) or self.energy_allows(a.task_type, a.location) for a, _, u in bids
        ):
            return bids
        return [(a, rnd, -math.inf) for a, rnd, _ in bids]

    def energy_allows(self, task_type: str, where: Point) -> bool:
        """Could I do this task and still reach a charger (`Robot`)?"""
        raise NotImplementedError

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
        prev = self.my_bids.get(a.auction_id)
        self.my_bids[a.auction_id] = (rnd, utility)
        self._refused = None
        self._quiet_on = None
        if (
            self._silent_when_busy
            and utility == -math.inf
            and (prev is None or not math.isfinite(prev[1]))
        ):
            return  # busy_bid = silent: no finite bid of mine to withdraw, so -inf says nothing
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
