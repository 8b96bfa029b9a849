"""What a bidder knows of the open auctions it could serve (`KnownAuctions`), kept apart from
the bidder (`engine.robots.bidder`) that decides and sends its bids from it.

It exists because this bookkeeping has invariants of its own, kept as auctions come and go
and bids are sent, not recomputed: the auctions by opening order (`in_order`, updated by
bisection), minus those of auctioneers thought down, and beside that list the auctions in
which a busy bidder may still have something to say (`unsaid`).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from operator import attrgetter
from typing import Protocol

from engine.bidding import OpenAuction

_OPENING = attrgetter("order")
"""An open auction's place in opening order (`OpenAuction.order`), as a sort key."""


class ListingRobot(Protocol):
    """What the book needs of its robot: the peers it thinks down (their auctions are not
    listed in `in_order`)."""

    @property
    def down(self) -> set[str]: ...


class KnownAuctions:
    """The open auctions a bidder can serve, by opening order, and those it may still bid in.

    `sent` is the bidder's own record of its bids (`Bidder.my_bids`, auction id -> round and
    utility): read here, written by the bidder, which tells the book of each bid it sends
    (`note_bid`). `stir` is called whenever `in_order` changes (the board of rounds visits a
    bidder again only once something it bids from changed)."""

    def __init__(
        self, robot: ListingRobot, sent: dict[str, tuple[int, float]], stir: Callable[[], None]
    ) -> None:
        self.robot = robot
        self.sent = sent
        self._stir = stir
        self.biddable: dict[str, OpenAuction] = {}  # announced, open, and I can serve them
        self.in_order: list[OpenAuction] | None = None  # biddable by opening order
        # the auctions of in_order in which my bid is not -inf, and those I have not bid in at
        # all (kept with it; `unsaid`)
        self._unrefused: set[str] = set()
        self._unbid: set[str] = set()

    def note_auction(self, info: OpenAuction) -> None:
        """An auction I can serve opened. Its place in `in_order` is found by bisection
        rather than by sorting again: hundreds of robots hear each of hundreds of open
        auctions at scale, and a sort per announcement per robot was a tenth of a run."""
        self.biddable[info.auction_id] = info
        order = self.in_order
        if order is None or info.auctioneer in self.robot.down:
            return
        order = order.copy()  # a new list: a caller may still hold the old one
        bisect.insort(order, info, key=_OPENING)
        self.in_order = order
        self._stir()
        prev = self.sent.get(info.auction_id)
        if prev is None or prev[1] != -math.inf:
            self._unrefused.add(info.auction_id)
        if prev is None:
            self._unbid.add(info.auction_id)

    def forget_auction(self, auction_id: str) -> OpenAuction | None:
        info = self.biddable.pop(auction_id, None)
        order = self.in_order
        if info is None or order is None or info.auctioneer in self.robot.down:
            return info
        order = order.copy()
        del order[bisect.bisect_left(order, info.order, key=_OPENING)]  # openings are unique
        self.in_order = order
        self._stir()
        self._unrefused.discard(auction_id)
        self._unbid.discard(auction_id)
        return info

    def auctions_in_order(self) -> list[OpenAuction]:
        """Open auctions I can serve, by opening order, minus those of auctioneers I think down."""
        if self.in_order is None:
            down = self.robot.down
            self.in_order = sorted(
                (a for a in self.biddable.values() if a.auctioneer not in down),
                key=_OPENING,
            )
            sent = self.sent
            self._unrefused = {
                a.auction_id
                for a in self.in_order
                if (prev := sent.get(a.auction_id)) is None or prev[1] != -math.inf
            }
            self._unbid = {a.auction_id for a in self.in_order if a.auction_id not in sent}
        return self.in_order

    def auctioneers_changed(self) -> None:
        """A peer was found down or came back: its auctions count again, or no more."""
        self.in_order = None
        self._stir()

    def note_bid(self, aid: str, utility: float) -> None:
        """I bid `utility` in this auction (already in `sent`): `unsaid` follows."""
        info = self.biddable.get(aid)
        listed = info is not None and info.auctioneer not in self.robot.down
        if self.in_order is not None and listed:  # an auction of in_order
            if utility == -math.inf:
                self._unrefused.discard(aid)
            else:
                self._unrefused.add(aid)
            self._unbid.discard(aid)

    def unsaid(self, once: bool) -> set[str]:
        """The open auctions I can serve in which, busy, I may still have something to say:
        those I have not bid -inf in (`once`, `Policy.busy_bids_once`: not bid in at all).
        Kept wherever `in_order` or `sent` changes (a busy Policy 4 robot used to scan
        every open auction, thousands at scale 100, after each of its bids)."""
        self.auctions_in_order()
        return self._unbid if once else self._unrefused

    def unsaid_in_order(self, once: bool) -> list[OpenAuction]:
        """`unsaid` in the order of `auctions_in_order`: a busy robot that bids in every
        auction, Policy 3's or 4's, scanned thousands at scale 100 to find the few it may
        still bid in."""
        biddable = self.biddable
        return sorted((biddable[aid] for aid in self.unsaid(once)), key=_OPENING)
