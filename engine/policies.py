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

from engine.messages import Location, TaskType


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

    def transport_lead_s(self) -> float:
        """How long before the bucket fills the excavator auctions its transport (0: when full)."""
        return 0.0


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


POLICIES: dict[str, type[Policy]] = {
    p.name: p for p in (FirstComeFirstServed, AnticipatoryCoalitions, NearestFirst)
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
