"""The auction's pure part (docs/spec.md §6): what an auction records and how it decides.

The records (`AuctionRecord` with its `BidRecord`s and `AwardRecord`s), the decisions
(`rank_bids`) and an auctioneer's responsibilities (`Allocation`, `Duties`).
No simpy and no clock here: `engine.auction_house` runs the protocol over time with them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from engine.messages import Location, TaskType

AUCTION_KINDS = {"scout": "scout_excavator", "excavator": "excavator_hauler"}


@dataclass(slots=True)
class BidRecord:
    t: float
    bidder: str
    utility: float
    round: int


@dataclass(slots=True)
class AwardRecord:
    t: float
    winner: str
    outcome: str = "pending"  # accepted | declined | timeout


@dataclass
class AuctionRecord:
    """Everything that happened in one auction, as the observer records it."""

    id: str
    kind: str
    auctioneer: str
    task_type: TaskType
    location: Location
    task_id: str
    opened_at: float
    policy: str
    status: str = "open"  # open | closed | cancelled | superseded
    closed_at: float | None = None
    allocated_to: str | None = None
    reannouncements: int = 0
    round: int = 0
    reauction_of: str | None = None
    search_path: tuple[Location, ...] = ()
    bids: list[BidRecord] = field(default_factory=list)
    awards: list[AwardRecord] = field(default_factory=list)

    @property
    def open_time(self) -> float | None:
        return None if self.closed_at is None else self.closed_at - self.opened_at

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "kind": self.kind,
            "auctioneer": self.auctioneer,
            "task_type": self.task_type,
            "task_id": self.task_id,
            "location": [self.location[0], self.location[1]],
            "status": self.status,
            "opened_at": self.opened_at,
            "closed_at": self.closed_at,
            "allocated_to": self.allocated_to,
            "reannouncements": self.reannouncements,
            "reauction_of": self.reauction_of,
            "policy": self.policy,
            "bids": [
                {
                    "t": b.t,
                    "bidder": b.bidder,
                    "utility": b.utility if math.isfinite(b.utility) else None,
                    "round": b.round,
                }
                for b in self.bids
            ],
            "awards": [{"t": a.t, "winner": a.winner, "outcome": a.outcome} for a in self.awards],
        }


def rank_bids(
    bids: Mapping[str, float],
    excluded: Iterable[str] = (),
    break_tie: Callable[[Sequence[str]], str] | None = None,
) -> list[str]:
    """Bidders by utility, best first; never a -inf bidder. Ties go to the smaller name, except
    that `break_tie`, given the bidders tied exactly at the top (sorted by name), picks which
    of them comes first (the policy's hook at the auctioneer, `Policy.break_tie`)."""
    skip = set(excluded)
    finite = [(u, b) for b, u in bids.items() if math.isfinite(u) and b not in skip]
    finite.sort(key=lambda ub: (-ub[0], ub[1]))
    ranked = [b for _, b in finite]
    if break_tie is not None and len(finite) > 1 and finite[1][0] == finite[0][0]:
        top = finite[0][0]
        tied = [b for u, b in finite if u == top]
        first = break_tie(tied)
        if first not in tied:
            raise ValueError(f"break_tie chose {first!r}, not one of the tied {tied}")
        ranked.remove(first)
        ranked.insert(0, first)
    return ranked


@dataclass(slots=True)
class Allocation:
    """A task this auctioneer handed out and now watches."""

    auction_id: str
    task_id: str
    task_type: TaskType
    location: Location
    winner: str
    since: float
    search_path: tuple[Location, ...] = ()


@dataclass
class Duties:
    """An auctioneer's responsibilities: its open auctions and the tasks it watches."""

    auctions: list[AuctionRecord] = field(default_factory=list)
    watches: dict[str, Allocation] = field(default_factory=dict)

    def task_ids(self) -> set[str]:
        return {r.task_id for r in self.auctions} | set(self.watches)

    def without(self, task_ids: set[str]) -> Duties:
        return Duties(
            [r for r in self.auctions if r.task_id not in task_ids],
            {t: a for t, a in self.watches.items() if t not in task_ids},
        )

    def merge(self, other: Duties) -> Duties:
        known = {r.task_id for r in self.auctions}
        extra = [r for r in other.auctions if r.task_id not in known]
        return Duties(self.auctions + extra, {**other.watches, **self.watches})
