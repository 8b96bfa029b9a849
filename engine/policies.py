"""How a robot treats several open auctions (SPEC §6), behind one interface.

A policy answers four questions, each a pure function of what the robot itself knows:
which open auctions to bid in now, whether to gather simultaneous awards before answering,
whether excavator–hauler coalitions are active, and when an excavator auctions the transport
of its next mineral. A new policy is a subclass registered in `POLICIES`; nothing in the
protocol changes.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from engine.messages import Location, TaskType

if TYPE_CHECKING:
    from engine.central import Allocator


@dataclass(frozen=True, slots=True)
class OpenAuction:
    """What a bidder knows of an auction, from its announcement."""

    auction_id: str
    auctioneer: str
    task_type: TaskType
    location: Location
    task_id: str
    opened_at: float
    search_path: tuple[Location, ...] = ()

    @property
    def order(self) -> tuple[float, str]:
        return (self.opened_at, self.auction_id)


@dataclass(frozen=True, slots=True)
class PendingAward:
    auction: OpenAuction
    utility: float


class Policy:
    name = "base"
    number = 0
    description = ""

    def bid_targets(
        self, rtype: str, in_coalition: bool, auctions: Sequence[OpenAuction]
    ) -> list[OpenAuction]:
        """Of the open auctions the robot can serve, given in opening order, those it bids in now.

        `in_coalition` is true for a hauler that is paired with a live excavator under a
        coalition policy.
        """
        raise NotImplementedError

    def collects_awards(self) -> bool:
        """Gather awards that arrive together and keep only the best?"""
        return False

    def choose_award(self, awards: Sequence[PendingAward]) -> PendingAward:
        """Of several awards, the one to accept: highest utility, then earliest opened."""
        return min(awards, key=lambda a: (-a.utility, a.auction.order))

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

    def bids_time(self) -> bool:
        """Bid the negated expected arrival time (seconds: time until free + travel) instead of
        the negated path length (metres)?"""
        return False

    def allocator(self) -> Allocator | None:
        """An oracle that picks auction winners from global state (the centralized baseline);
        None: the auctioneer ranks the bids (SPEC §5)."""
        return None


def earliest(auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
    """The auction that opened first (the list comes in opening order)."""
    return [auctions[0]] if auctions else []


class FirstComeFirstServed(Policy):
    """Policy 1: bid only in the auction that opened first, until it closes."""

    name, number = "fcfs", 1
    description = "first come, first served"

    def bid_targets(
        self, rtype: str, in_coalition: bool, auctions: Sequence[OpenAuction]
    ) -> list[OpenAuction]:
        return earliest(auctions)


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


class AnticipatoryCoalitions(FirstComeFirstServed):
    """Policy 2: paired haulers follow their excavator and never bid; others bid as Policy 1."""

    name, number = "coalition", 2
    description = "anticipatory coalitions"

    def bid_targets(
        self, rtype: str, in_coalition: bool, auctions: Sequence[OpenAuction]
    ) -> list[OpenAuction]:
        if rtype == "hauler" and in_coalition:
            return []
        return earliest(auctions)

    def coalitions(self) -> bool:
        return True


class NearestFirst(Policy):
    """Policy 3: bid in every open auction; of several awards keep the nearest, decline the rest."""

    name, number = "nearest", 3
    description = "nearest first"

    def bid_targets(
        self, rtype: str, in_coalition: bool, auctions: Sequence[OpenAuction]
    ) -> list[OpenAuction]:
        return list(auctions)

    def collects_awards(self) -> bool:
        return True


class Lookahead(Policy):
    """Policy 4: act on what is about to happen (rules, reasons, measurements: docs/policies.md).

    - every mineral's transport is auctioned one hauler drive (from the plant) plus one dig
      before its bucket is expected to fill — the first one while the excavator is still on
      its way — so a hauler stands by when the bucket fills;
    - robots bid the negated expected arrival time (finish what they hold, then drive) and may
      hold `queue` tasks beside the current one;
    - everyone bids in every open auction and keeps the best of simultaneous awards.

    The class attributes switch the rules off one at a time, for the measurements.
    """

    name, number = "lookahead", 4
    description = "lookahead: early transport auctions, arrival-time bids, one-task queues"
    lead = True
    queue: dict[str, int] = {"hauler": 1, "excavator": 1}  # noqa: RUF012 - read-only table
    time_bids = True
    bid_all = True

    def bid_targets(
        self, rtype: str, in_coalition: bool, auctions: Sequence[OpenAuction]
    ) -> list[OpenAuction]:
        return list(auctions) if self.bid_all else earliest(auctions)

    def collects_awards(self) -> bool:
        return self.bid_all

    def transport_lead_s(self, haul_s: float, dig_s: float) -> float:
        return haul_s + dig_s if self.lead else 0.0

    def early_transports(self) -> bool:
        return self.lead

    def queue_limit(self, rtype: str) -> int:
        return self.queue.get(rtype, 0)

    def bids_time(self) -> bool:
        return self.time_bids


class Central(Policy):
    """The centralized baseline (number 0): an oracle with global knowledge picks every
    auction's winner by an optimal assignment (engine/central.py). Robots bid in every open
    auction, so the records look like the others'; the bids do not decide anything."""

    name, number = "central", 0
    description = "centralized oracle baseline (optimal assignment, global knowledge)"
    lead = True  # Policy 4's early transport auctions, so only the allocation differs

    def bid_targets(
        self, rtype: str, in_coalition: bool, auctions: Sequence[OpenAuction]
    ) -> list[OpenAuction]:
        return list(auctions)

    def transport_lead_s(self, haul_s: float, dig_s: float) -> float:
        return haul_s + dig_s if self.lead else 0.0

    def early_transports(self) -> bool:
        return self.lead

    def allocator(self) -> Allocator | None:
        from engine.central import OracleAllocator

        return OracleAllocator()


POLICIES: dict[str, type[Policy]] = {
    p.name: p
    for p in (FirstComeFirstServed, AnticipatoryCoalitions, NearestFirst, Lookahead, Central)
}
POLICY_NAMES: dict[int, str] = {p.number: p.name for p in POLICIES.values()}


def register_policy(cls: type[Policy]) -> type[Policy]:
    """Plug a new policy in (usable as a class decorator)."""
    POLICIES[cls.name] = cls
    POLICY_NAMES[cls.number] = cls.name
    return cls


def resolve_policy(value: str | int) -> str:
    """'2', 2 or 'coalition' → 'coalition'; raises ValueError naming the choices."""
    text = str(value).strip().lower()
    if text.isdigit() and int(text) in POLICY_NAMES:
        return POLICY_NAMES[int(text)]
    if text in POLICIES:
        return text
    choices = ", ".join(f"{n}|{name}" for n, name in sorted(POLICY_NAMES.items()))
    raise ValueError(f"policy: unknown policy {value!r} (choose one of {choices})")


def make_policy(name: str | int) -> Policy:
    return POLICIES[resolve_policy(name)]()
