"""The researcher's record of one run: the event log, the auction records and the counters.

Bookkeeping only: no robot decision reads it. The auctioneers write their records through it
(by way of the mission context, `engine.auction_ports.AuctionPorts`), the field reports what
happens on the ground to it, and it notes when the mission last moved forward, for the
stall watch.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from engine.auction_rules import AuctionRecord
from engine.events import Event, EventLog
from engine.messages import Bid, Location, Message, TaskType

PROGRESS = frozenset(
    {"site_found", "dug", "pickup", "delivered", "mineral_recovered", "auction_closed"}
)
"""Events that move the mission forward; a long time with none of them (and no new cell
scanned, no operator action) is a stall."""


class Observer:
    def __init__(self, clock: Callable[[], float]) -> None:
        self._clock = clock
        self.log = EventLog(clock)
        self.progress_at = 0.0
        self.log.subscribe(self._note_progress, payloads=False)
        self.auctions: list[AuctionRecord] = []
        self.auctions_by_id: dict[str, AuctionRecord] = {}
        self._serial: dict[str, int] = {}
        self.life = 1
        """Which life of its process this record's robots live (field mode: a robot's agent
        started again is a new life, counting its auctions and minerals from 1 again)."""
        self.bids = 0
        self.declines = 0
        self.failures = 0
        self.reauctions = 0
        self.dropped = 0
        self.recovered = 0

    def emit(self, kind: str, /, **data: Any) -> None:
        self.log.emit(kind, **data)

    def _note_progress(self, ev: Event) -> None:
        if ev.kind in PROGRESS:
            self.progress_at = ev.t

    def record_message(self, msg: Message) -> None:
        """Every message said, as a `message` event (counted only, when nobody reads the
        log's payloads); a bid also as a `bid` event."""
        log = self.log
        if log.unread:
            log.count_unread("message")  # not a PROGRESS kind: nothing watches it
        else:
            log.append("message", msg.to_dict())
        if isinstance(msg, Bid):
            self.bids += 1
            log.append(
                "bid",
                {
                    "auction_id": msg.auction_id,
                    "bidder": msg.bidder,
                    "utility": msg.utility if math.isfinite(msg.utility) else None,
                    "round": msg.round,
                },
            )

    def of_this_life(self, ident: str) -> str:
        """`ident` (an auction's or a task's id a robot made) marked with a later life: a new
        life's `scout-1/2` or `excavator-1#m0` is `...@2`, never an earlier life's own."""
        return ident if self.life == 1 else f"{ident}@{self.life}"

    def new_auction(
        self,
        auctioneer: str,
        kind: str,
        task_type: TaskType,
        location: Location,
        task_id: str,
        search_path: tuple[Location, ...],
        reauction_of: str | None,
        policy: str,
    ) -> AuctionRecord:
        n = self._serial.get(auctioneer, 0) + 1
        self._serial[auctioneer] = n
        rec = AuctionRecord(
            id=self.of_this_life(f"{auctioneer}/{n}"),
            kind=kind,
            auctioneer=auctioneer,
            task_type=task_type,
            location=location,
            task_id=task_id,
            opened_at=self._clock(),
            policy=policy,
            reauction_of=reauction_of,
            search_path=search_path,
        )
        self.auctions.append(rec)
        self.auctions_by_id[rec.id] = rec
        if reauction_of is not None:
            self.reauctions += 1
            old = self.auctions_by_id.get(reauction_of)
            if old is not None and old.status == "open":
                self.close_auction(old, "superseded", None)
        self.log.emit(
            "auction_opened",
            auction_id=rec.id,
            kind=kind,
            auctioneer=auctioneer,
            task_type=task_type,
            task_id=task_id,
            location=list(location),
            reauction_of=reauction_of,
        )
        return rec

    def close_auction(self, rec: AuctionRecord, status: str, winner: str | None) -> None:
        for award in rec.awards:
            if award.outcome == "pending":  # cancelled or superseded while the winner pondered
                award.outcome = "withdrawn"
        rec.status = status
        rec.closed_at = self._clock()
        rec.allocated_to = winner
        kind = "auction_closed" if status == "closed" else f"auction_{status}"
        self.log.emit(kind, auction_id=rec.id, allocated_to=winner, open_s=rec.open_time)

    def note_decline(self, rec: AuctionRecord, winner: str, outcome: str) -> None:
        self.declines += 1
        self.log.emit("auction_declined", auction_id=rec.id, bidder=winner, outcome=outcome)
