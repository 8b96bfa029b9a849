"""The bidding part of a robot that can carry out tasks (docs/spec.md §6.2–6.5): the open
auctions it could serve (its book of them: `engine.robots.known_auctions`), which to bid in
(the policy decides), the utility it bids, answering awards, and holding an accepted award
until the auctioneer's Close confirms it.

Scouts and the operator carry out no auctioned task and have no bidding part. The policy
reads the robot through this part (`engine.bidding.RobotView`).
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING, Any, Protocol

import simpy

from engine.bidding import BidMemory, Bids, OpenAuction, refused_all
from engine.geometry import Point
from engine.messages import Ack, Award, Bid, Heartbeat, TaskType
from engine.policies import PendingAward, Policy
from engine.robots.known_auctions import KnownAuctions
from engine.robots.pricing import PeerWatch, Pricing
from engine.round_board import Rounds

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.energy import Battery
    from engine.robots.charging import Charging
    from engine.robots.core import Assignment
    from engine.robots.mobility import Mobility


class BiddingRobot(Protocol):
    """What the bidding part needs of its robot: who and where it is, what it holds, and the
    type's own answers to the policy (`free_at`, and for coalitions `paired`,
    `partner_working`, `transports_stranded`)."""

    name: str
    rtype: str
    ctx: MissionContext
    battery: Battery | None
    mobility: Mobility
    charging: Charging | None
    current: Assignment | None
    queue: deque[Assignment]
    rounds: Rounds
    partner: str | None

    @property
    def recovery(self) -> PeerWatch: ...

    @property
    def capability(self) -> TaskType | None: ...
    @property
    def participating(self) -> bool: ...
    @property
    def down(self) -> set[str]: ...
    def load(self) -> int: ...
    def spawn(self, gen: Any) -> None: ...
    def free_at(self) -> tuple[float, Point]: ...
    def paired(self) -> bool: ...
    def partner_working(self) -> bool: ...
    def transports_stranded(self) -> bool: ...


class Bidder(Pricing):
    """The bidder role of a robot, and its view for the policy (`Pricing`)."""

    robot: BiddingRobot

    def __init__(self, robot: BiddingRobot) -> None:
        self.robot = robot
        self.name = robot.name
        self.rtype = robot.rtype
        self.ctx = robot.ctx
        self.env = robot.ctx.env
        protocol = robot.ctx.scenario.protocol
        self._every_round = protocol.busy_bid == "every_round"
        self._silent_when_busy = protocol.busy_bid == "silent"
        # the ideal bus's board of rounds visits me on a re-announcement only while I may not
        # be quiet (`stays_quiet`): whatever can end my quiet stirs me there (`_stir`)
        self._board = robot.ctx.bus.board
        self.reset()
        if self._board is not None:
            self._board.bidder(self.name, self)

    def _stir(self) -> None:
        if self._board is not None:
            self._board.stir(self.name)

    def reset(self) -> None:
        """Forget everything heard (a new life after a failure)."""
        self.my_bids: dict[str, tuple[int, float]] = {}
        # the open auctions I can serve, and those I may still bid in (`KnownAuctions`)
        self.known = KnownAuctions(self.robot, self.my_bids, self._stir)
        # the same dict as the book's (hearing and the board of rounds ask it here)
        self.biddable: dict[str, OpenAuction] = self.known.biddable
        self._quiet_on: list[OpenAuction] | None = None  # busy with nothing to send
        self._quiet_policy: Policy | None = None
        self._bid_situation: tuple[object, ...] = ()  # what my time bids were computed from
        self.reserved: OpenAuction | None = None
        self.pending_awards: list[PendingAward] = []
        self._stir()

    # --- what I know of the auctions I could serve ---------------------------------------
    def note_auction(self, info: OpenAuction) -> None:
        """An auction I can serve opened (`KnownAuctions.note_auction`)."""
        self.known.note_auction(info)

    def forget_auction(self, auction_id: str) -> OpenAuction | None:
        self.robot.rounds.forget(auction_id)
        return self.known.forget_auction(auction_id)

    def auctioneers_changed(self) -> None:
        """A peer was found down or came back: its auctions count again, or no more."""
        self.known.auctioneers_changed()

    def closed(self, auction_id: str) -> OpenAuction | None:
        """The auction closed (its Close): forgotten, with my bid in it."""
        info = self.forget_auction(auction_id)
        if self.my_bids.pop(auction_id, None) is not None:
            self._quiet_on = None
            self._stir()
        return info

    def missed_closes(self) -> None:
        """An auction whose auctioneer no longer lists it has closed (its Close was missed).

        Where every living robot hears every Close as it is sent (`Bus.closes_reach_all`),
        only an auction that ended without one can be: its auctioneer failed. Looking only at
        those gives the same forgetting without a heartbeat look-up for every auction I know
        at every heartbeat (7.5 % of a scale-100 mission)."""
        board = self.ctx.liveness
        latest: dict[str, Heartbeat | None] = {}
        for aid, info in self._may_have_missed():
            who = info.auctioneer
            hb = (
                latest[who]
                if who in latest
                else latest.setdefault(who, board.last_heartbeat(self.robot.name, who))
            )
            if hb is not None and hb.t > info.opened_at + 1e-9 and aid not in hb.open_auctions:
                self.forget_auction(aid)

    def _may_have_missed(self) -> list[tuple[str, OpenAuction]]:
        """The auctions I know whose Close I may have missed, in the order I learnt of them."""
        bus, biddable = self.ctx.bus, self.biddable
        if not bus.closes_reach_all:
            return list(biddable.items())
        unclosed = bus.unclosed
        if not any(aid in biddable for aid in unclosed):
            return []
        return [(aid, info) for aid, info in biddable.items() if aid in unclosed]

    def auctioneer_down(self, peer: str) -> None:
        """A silent or departed auctioneer's auctions are forgotten, its award let go."""
        for aid, info in list(self.biddable.items()):
            if info.auctioneer == peer:
                self.forget_auction(aid)
        if self.reserved is not None and self.reserved.auctioneer == peer:
            self.let_go()

    # --- awards -------------------------------------------------------------------------
    def on_award(self, msg: Award) -> None:
        if msg.winner != self.robot.name:
            return
        info = self.biddable.get(msg.auction_id)
        bid = self.my_bids.get(msg.auction_id)
        if (
            info is None
            or bid is None
            or not self.can_take()
            or not self._allowed(info.task_type, info.location)
        ):
            self._answer(msg.auction_id, msg.auctioneer, msg.location, False)
            return
        award = PendingAward(info, bid[1])
        if self.ctx.policy.collects_awards():
            self.pending_awards.append(award)
            if len(self.pending_awards) == 1:
                self.robot.spawn(self._resolve_awards())
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
        self.robot.spawn(self._reservation_timer(a))

    def _answer(self, auction_id: str, auctioneer: str, location: Point, yes: bool) -> None:
        self.ctx.bus.publish(
            Ack(
                sender=self.robot.name,
                auction_id=auction_id,
                auctioneer=auctioneer,
                winner=self.robot.name,
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
            self.let_go()
            self.consider_bids()

    def let_go(self) -> None:
        """My reservation ends (confirmed, lost or unconfirmed in time): room again."""
        self.reserved = None
        self._stir()

    def revoked(self, task_id: str) -> None:
        """A Revoke of `task_id` reached me before the Close allocating it (a bus that
        reorders: the Close was sent first): that Close must not start it."""
        if self.reserved is not None and self.reserved.task_id == task_id:
            self.let_go()

    # --- room for more ------------------------------------------------------------------
    def busy(self) -> bool:
        robot = self.robot
        return self.reserved is not None or robot.current is not None or bool(robot.queue)

    def can_take(self) -> bool:
        return self.robot.participating and self.has_room()

    def held(self) -> int:
        """Tasks won and not finished: the current one and the queue."""
        return (self.robot.current is not None) + len(self.robot.queue)

    def has_room(self) -> bool:
        """Free to win one more task: nothing reserved and no more held than the policy lets
        a robot queue (under Policies 1–3, exactly `not busy()`)."""
        robot = self.robot
        battery = robot.battery
        return (
            self.reserved is None
            and (robot.current is not None) + len(robot.queue)  # held(), asked millions of times
            <= self.ctx.policy.queue_limit(self.rtype)
            and (battery is None or not battery.must_charge)
        )

    # --- bidding ------------------------------------------------------------------------
    def look_afresh(self) -> None:
        """Something my time bids come from changed outside my view (a new policy, a full
        battery): look at everything afresh."""
        self._bid_situation = ()
        self.consider_bids()

    def consider_bids(self) -> None:
        """Send the bids my policy asks for, given what I know (`engine/bidding.py`)."""
        robot = self.robot
        if not robot.participating or robot.capability is None:
            return
        known = self.known
        auctions = known.auctions_in_order()
        if not auctions:
            return
        policy = self.ctx.policy
        busy = not self.has_room()
        every_round = self._every_round
        quiet = busy and not every_round
        if quiet and self._quiet_on is auctions and self._quiet_policy is policy:
            return  # busy, and nothing I bid from changed since I last had nothing to send
        situation = (
            busy,
            robot.current,
            len(robot.queue),
            self.reserved,
            robot.load(),
            robot.mobility.pos,
        )
        once = quiet and policy.busy_bids_once()  # read only when quiet
        if quiet and policy.targets_pure and not known.unsaid(once):
            # no room, and -inf (`once`: anything) said in every auction I know: no bid,
            # whatever the targets
            self._bid_situation = situation
            self._note_quiet(auctions, policy)
            return
        targets = policy.bid_targets(self, auctions)
        if quiet and policy.targets_pure and targets == auctions:
            # the whole list, answered just above (`unsaid`): some I have not refused.
            # A refused target adds no bid (`Policy.targets_from_list`; `once`, nor one I bid
            # in at all): ask about the others
            if policy.targets_from_list_for(self):
                targets = known.unsaid_in_order(once)
        elif quiet and refused_all(self.my_bids, targets, once):
            self._bid_situation = situation
            self._note_quiet(auctions, policy)
            return
        mem = BidMemory(
            busy=busy,
            sent=self.my_bids,
            rounds=robot.rounds,
            changed=situation != self._bid_situation,
            every_round=every_round,
        )
        self._bid_situation = situation
        bids = policy.bids(self, targets, mem)
        if robot.battery is not None:
            bids = self._within_reach(bids)
        for a, rnd, utility in bids:
            self._bid(a, rnd, utility)

    def stays_quiet(self) -> bool:
        """Would `consider_bids` send nothing? Asked by the ideal bus's first look at a
        re-announcement (`Robot.first_look`), so that such a robot only notes the round
        instead of going through the whole handler."""
        return self.quiet_until() is not None

    def quiet_until(self) -> float | None:
        """Up to when `consider_bids` sends nothing unless I am stirred (None: it may send
        now). Busy, with neither my auction list nor the policy changed since I last had
        nothing to send (`_note_quiet`): until stirred. Or a policy's promise of no targets
        whatever the list (`Policy.no_targets_until`): until its time."""
        order = self.known.in_order
        policy = self.ctx.policy
        if (
            order is not None
            and self._quiet_on is order
            and self._quiet_policy is policy
            and not self._every_round
            and not self.has_room()
        ):
            return math.inf
        until = policy.no_targets_until(self)
        return until if until is not None and until > self.env.now else None

    def _note_quiet(self, auctions: list[OpenAuction], policy: Policy) -> None:
        """Remember that, busy, I had nothing to send for this list (an object never changed
        in place) and my bids as they are: under a policy whose targets come from the list
        alone for me (`Policy.targets_from_list_for`), asking again before either changes
        gives the same nothing."""
        if policy.targets_from_list_for(self):
            self._quiet_on, self._quiet_policy = auctions, policy
            if self._board is not None:
                self._board.settle(self.name)

    def _within_reach(self, bids: Bids) -> Bids:
        """Energy: a task I could not finish and still reach a charger gets -inf, and then I
        go to charge (so does every other bid of this look: I am busy charging)."""
        allows = self._allowed
        if all(not math.isfinite(u) or allows(a.task_type, a.location) for a, _, u in bids):
            return bids
        return [(a, rnd, -math.inf) for a, rnd, _ in bids]

    def _allowed(self, task_type: str, where: Point) -> bool:
        """Energy: could I do this task and still reach a charger (no battery: yes)?"""
        charging = self.robot.charging
        return charging is None or charging.allows(task_type, where)

    def _bid(self, a: OpenAuction, rnd: int, utility: float) -> None:
        aid = a.auction_id
        prev = self.my_bids.get(aid)
        self.my_bids[aid] = (rnd, utility)
        self.known.note_bid(aid, utility)
        self._quiet_on = None
        if (
            self._silent_when_busy
            and utility == -math.inf
            and (prev is None or not math.isfinite(prev[1]))
        ):
            return  # busy_bid = silent: no finite bid of mine to withdraw, so -inf says nothing
        self.ctx.bus.publish(
            Bid(
                sender=self.robot.name,
                auction_id=a.auction_id,
                auctioneer=a.auctioneer,
                bidder=self.robot.name,
                location=a.location,
                utility=utility,
                round=rnd,
            )
        )
