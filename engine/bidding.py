"""The two bidding rules a policy chooses from, as pure functions of what a robot knows.

A robot hands its policy a read-only view of itself and the memory of its own bids; the
policy answers with the bids to send. Nothing here sends, waits or reads the mission.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from engine.messages import Location, TaskType

REBID_S = 2.0
"""A time-bidding robot re-sends a bid when its estimate moved by more than this (seconds)."""


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


Bids = list[tuple[OpenAuction, int, float]]
"""Bids to send: the auction, the round it is for, the utility (-inf: capable but busy)."""


class RobotView(Protocol):
    """What a policy may read of a robot."""

    name: str
    rtype: str

    def paired(self) -> bool:
        """A hauler paired with a live excavator under a coalition policy (Policy 2)."""
        ...

    def has_partner(self) -> bool:
        """A coalition partner by name (Policy 2's pairing), on the team or not: fixed for the
        robot's life, so a quiet noted on it holds (whether the partner is on the team is
        not: in field mode a robot learns its peers as it hears them)."""
        ...

    def partner_working(self) -> bool:
        """That partner has a site to work (the hauler follows it there)."""
        ...

    def paired_until(self) -> float:
        """The time up to which `paired` stays true unless something stirs this robot first
        (its partner found down, a new policy): the partner's last hearing plus the failure
        timeout; -inf when not paired."""
        ...

    def transports_stranded(self) -> bool:
        """Nobody but a paired hauler could carry a transport: no unpaired hauler is alive, as
        far as this robot knows (the same answer for every transport, asked once a look)."""
        ...

    def cost_to(self, a: OpenAuction) -> float: ...
    def eta_to(self, a: OpenAuction) -> float: ...


@dataclass(frozen=True, slots=True)
class BidMemory:
    """A robot's own bidding state: whether it has room for one more task, what it last bid
    in each auction (round, utility), the latest round of each, and whether its own situation
    (tasks, load, position) changed since its last look."""

    busy: bool
    sent: Mapping[str, tuple[int, float]]
    rounds: Mapping[str, int]
    changed: bool
    every_round: bool  # scenario protocol: a busy robot's -inf on every round, not once


def refused_all(
    sent: Mapping[str, tuple[int, float]], targets: Sequence[OpenAuction], once: bool = False
) -> bool:
    """Has the robot bid -inf in every one of these auctions (`once`: bid anything at all)?
    Then, while it is busy (and `every_round` is off), neither rule below sends anything (with
    `once`, `distance_bids` only, which never withdraws a finite bid): a robot may skip asking
    them. Most robots are busy most of the time, and each hears every announcement."""
    for a in targets:
        prev = sent.get(a.auction_id)
        if prev is None or (prev[1] != -math.inf and not once):
            return False
    return True


def distance_bids(view: RobotView, targets: Sequence[OpenAuction], mem: BidMemory) -> Bids:
    """docs/spec.md §6.2: utility = -(path length to the task). A new auction or round gets
    a bid; a busy robot says -inf once per auction (or every round, if configured)."""
    out: Bids = []
    for a in targets:
        prev = mem.sent.get(a.auction_id)
        rnd = mem.rounds.get(a.auction_id, 0)
        if mem.busy:
            if prev is None or (mem.every_round and prev[0] != rnd):
                out.append((a, rnd, -math.inf))
        elif prev is None or prev[0] != rnd or not math.isfinite(prev[1]):
            out.append((a, rnd, -view.cost_to(a)))
    return out


def time_bids(view: RobotView, targets: Sequence[OpenAuction], mem: BidMemory) -> Bids:
    """utility = -(expected arrival time: finish what it holds, then drive).

    Auctions (or rounds) not bid in yet get a bid. The others are looked at again only when
    the robot's own situation changed: then a bid is re-sent if the estimate moved by more
    than `REBID_S`, and a robot that has run out of room withdraws its finite bids with -inf,
    so a winner is rarely one that must decline. A busy robot's -inf goes once per auction.
    """
    out: Bids = []
    busy_once = mem.busy and not mem.every_round
    for a in targets:
        prev = mem.sent.get(a.auction_id)
        if busy_once and prev is not None and prev[1] == -math.inf:
            continue  # refused already: nothing more to say while busy (the round not read)
        rnd = mem.rounds.get(a.auction_id, 0)
        fresh = prev is None or prev[0] != rnd
        if not (fresh or mem.changed):
            continue
        if mem.busy:
            if prev is None or math.isfinite(prev[1]) or (mem.every_round and prev[0] != rnd):
                out.append((a, rnd, -math.inf))
            continue
        utility = -view.eta_to(a)
        if (
            prev is None
            or prev[0] != rnd
            or not math.isfinite(prev[1])
            or abs(prev[1] - utility) > REBID_S
        ):
            out.append((a, rnd, utility))
    return out
