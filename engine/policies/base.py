"""The policy interface (`Policy`), what a policy is given (`PolicyContext`) and what a bidder
holds of an award (`PendingAward`; what it knows of an auction, `OpenAuction`, is the
bidder's, in engine/bidding.py).

A policy is a strategy over a read-only view of the robot (`engine.bidding.RobotView`) and
what the robot knows; it answers, as pure functions: which open auctions to bid in
(`bid_targets`), what to bid and when to bid again (`bids`, choosing one of the rules in
engine/bidding.py), whether to gather simultaneous awards and which to keep
(`collects_awards`, `choose_award`), how many won tasks a robot may queue (`queue_limit`),
whether excavator–hauler coalitions are active (`coalitions`), when an excavator auctions
the transport of its next mineral (`transport_lead_s`), and, at the auctioneer, which of the
bidders tied exactly at the top is awarded first (`break_tie`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from engine.bidding import BidMemory, Bids, OpenAuction, RobotView, distance_bids
from engine.messages import Location

if TYPE_CHECKING:
    from engine.auction_rules import AuctionRecord
    from engine.central import Allocator
    from engine.global_view import GlobalView


@dataclass(frozen=True, slots=True)
class PendingAward:
    auction: OpenAuction
    utility: float


POLICY_STREAM = 4
"""The policies' random stream is child 4 of the run's `SeedSequence` (0–3: world, bus,
planner, work), so drawing from it changes none of the others."""


def policy_rng(seed: int) -> np.random.Generator:
    """A run's policy stream: its own child of `SeedSequence(seed)`, shared by every policy
    the run uses (a switch continues the stream, so a replayed history draws the same)."""
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(POLICY_STREAM + 1)[-1])


@dataclass(frozen=True, slots=True)
class PolicyContext:
    """What a policy is given: its seeded random stream, its parameters (over its class's
    `defaults`) and, for a policy that is not decentralized only, the mission's global view."""

    rng: np.random.Generator = field(default_factory=lambda: policy_rng(0))
    params: Mapping[str, Any] = field(default_factory=dict)
    global_view: GlobalView | None = None


class Policy:
    """The interface, and the metadata every registered policy states about itself."""

    number = -1
    name = "base"
    label = ""  # short human name for charts and menus ("Coalitions")
    colour = "#a3b1c2"  # one hex colour per policy, used by every chart and menu
    description = ""  # one line
    decentralized = True  # False: some unit with global knowledge decides (the baseline)
    defaults: ClassVar[Mapping[str, Any]] = {}
    """The policy's parameters and their values unless a variant or a run sets them."""
    targets_pure = True
    """`bid_targets` only reads: a robot that provably sends no bid may skip asking it."""
    targets_from_list = False
    """`bid_targets` reads nothing but the auction list, and for a busy robot `bids` sends
    nothing in a target it has bid -inf in, whatever `BidMemory.changed` says (both rules of
    engine/bidding.py): a busy robot that sent nothing need not ask again until the list or
    its own bids change (a hauler hears every re-announcement of every waiting transport),
    and one that bids in every auction is asked only about those it has not refused.
    A class that overrides either method states it again (`register_policy` checks)."""

    def targets_from_list_for(self, view: RobotView) -> bool:
        """`targets_from_list` for one robot: a policy whose targets read more than the list
        only for some robots says which here (Policy 2: a hauler's targets read its partner;
        its excavators, and haulers without a partner, bid as Policy 1). A class that
        overrides `bid_targets` or `bids` below the one that answers here answers again."""
        return self.targets_from_list

    def busy_bids_once(self) -> bool:
        """Does `bids` send a busy robot nothing in a target it has bid in at all, finite or
        -inf (`every_round` off)? True of `distance_bids`, the default: a finite bid made while
        free is never withdrawn. `time_bids` withdraws it, so there only -inf is final. Under
        a policy that answers yes, a quiet robot that bids in every auction is asked only about
        those it has not bid in (Policy 3's busy excavators keep finite bids in hundreds of
        sites at scale 100). A class that overrides `bids` answers again (`register_policy`
        checks)."""
        return True

    def no_targets_until(self, view: RobotView) -> float | None:
        """A time up to which `bid_targets` gives this robot nothing, whatever its auction
        list, unless something that stirs it changes first (engine/round_board.py: its
        tasks, its list, the policy; a partner's site). None: no such promise. Later rounds
        then leave it be until that time (Policy 2: a paired hauler whose partner works,
        until the partner could be declared silent)."""
        return None

    def __init__(self, context: PolicyContext | None = None) -> None:
        self.context = context if context is not None else PolicyContext()
        unknown = sorted(set(self.context.params) - set(self.defaults))
        if unknown:
            raise ValueError(f"{self.name}: unknown parameters {unknown}")
        self.params: dict[str, Any] = {**self.defaults, **self.context.params}

    @property
    def rng(self) -> np.random.Generator:
        """The run's policy stream (seeded from the mission seed, apart from every other)."""
        return self.context.rng

    @property
    def global_view(self) -> GlobalView:
        """The mission's true state: given only to a policy that is not decentralized."""
        view = self.context.global_view
        if view is None:
            raise RuntimeError(f"{self.name}: no global view (only a baseline is given one)")
        return view

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        """Of the open auctions the robot can serve, given in opening order, those it bids in now
        (the view says whether it is a hauler paired under a coalition policy, and more)."""
        raise NotImplementedError

    def bids(self, view: RobotView, targets: Sequence[OpenAuction], mem: BidMemory) -> Bids:
        """The bids to send now in the target auctions: the negated path length by default
        (docs/spec.md §6.2); `engine/bidding.py` holds the rules to choose from."""
        return distance_bids(view, targets, mem)

    def collects_awards(self) -> bool:
        """Gather awards that arrive together and keep only the best?"""
        return False

    def choose_award(self, awards: Sequence[PendingAward]) -> PendingAward:
        """Of several awards, the one to accept: highest utility, then earliest opened."""
        return min(awards, key=lambda a: (-a.utility, a.auction.order))

    def break_tie(self, auction: AuctionRecord, tied: Sequence[str]) -> str:
        """At the auctioneer: of the bidders whose bids tie exactly at the top (two or more,
        sorted by name), the one awarded first. The default: the smaller name."""
        return tied[0]

    def coalitions(self) -> bool:
        return False

    def transport_lead_s(self, haul_s: float, dig_s: float) -> float:
        """How long before a bucket is expected to fill the excavator auctions its transport
        (0: when it is full), given a hauler's straight drive from the plant to the site and
        the time one dig takes."""
        return 0.0

    def early_transports(self) -> bool:
        """Can a transport be auctioned before its excavator stands at the site with a full
        bucket (a positive transport lead)? Then a hauler that arrives first waits there."""
        return False

    def queue_limit(self, rtype: str) -> int:
        """How many won tasks a robot of this type may hold beside the one it works on and
        still bid a finite utility (0: a robot with any task is busy and bids -inf)."""
        return 0

    def allocator(self) -> Allocator | None:
        """An oracle that picks auction winners from the global view (the centralized
        baseline); None: the auctioneer ranks the bids (docs/spec.md §6)."""
        return None

    def standby(self, robot: str) -> Location | None:
        """Where a robot with nothing to do should wait (the offline reference's pre-placed
        robots); None: it waits where it is."""
        return None


def earliest(auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
    """The auction that opened first (the list comes in opening order)."""
    return [auctions[0]] if auctions else []


_NUMBER = re.compile(r"-(\d+)$")


def coalition_partner(name: str) -> str | None:
    """Policy 2's pairs: excavator-k works with hauler-k (a rule every robot can apply)."""
    m = _NUMBER.search(name)
    if m is None:
        return None
    if name.startswith("excavator-"):
        return f"hauler-{m.group(1)}"
    if name.startswith("hauler-"):
        return f"excavator-{m.group(1)}"
    return None
