"""The MURDOCH-variant auction (docs/spec.md §6) over time: first-price, one round, broadcast.

`AuctionHouse` is the auctioneer role any robot (or the operator) plays: it announces,
collects bids for the bid window, awards the best finite bid, moves to the next bidder on a
decline or a silent winner, re-announces after the retry interval when nobody can take the
task, and after the close monitors the winner until it reports the task done — re-auctioning
it if the winner falls silent. The records it keeps and the decisions it applies are the pure
`engine.auction_rules`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence, Set
from typing import TYPE_CHECKING, Any, Literal, Protocol

import simpy

from engine.auction_rules import (
    Allocation,
    AuctionRecord,
    AwardRecord,
    BidRecord,
    Duties,
    rank_bids,
)
from engine.messages import Ack, Announce, Award, Bid, Close, Location, Message, TaskType

if TYPE_CHECKING:
    from engine.scenario import Protocol as ProtocolSettings


class AuctionPorts(Protocol):
    """What an auctioneer needs of the mission, and nothing more: the clock, the protocol's
    timing, the bus, the observer's records, the policy's choice among bidders tied exactly at
    the top and, for the centralized baseline only, an oracle's award order (None: the
    auctioneer ranks the bids)."""

    env: simpy.Environment

    @property
    def protocol(self) -> ProtocolSettings: ...
    def publish(self, msg: Message) -> None: ...
    def emit(self, kind: str, /, **data: Any) -> None: ...
    def new_auction(
        self,
        auctioneer: str,
        kind: str,
        task_type: TaskType,
        location: Location,
        task_id: str,
        search_path: tuple[Location, ...],
        reauction_of: str | None,
    ) -> AuctionRecord: ...
    def close_auction(self, rec: AuctionRecord, status: str, winner: str | None) -> None: ...
    def note_decline(self, rec: AuctionRecord, winner: str, outcome: str) -> None: ...
    def oracle_rank(
        self, rec: AuctionRecord, bids: Mapping[str, float], excluded: Set[str]
    ) -> list[str] | None: ...
    def break_tie(self, rec: AuctionRecord, tied: Sequence[str]) -> str: ...


class _Live:
    """Per-auction working state of the auctioneer (not part of the record)."""

    __slots__ = ("ack", "declined", "live_bids", "process", "waiting_late", "wake")

    def __init__(self) -> None:
        self.live_bids: dict[str, float] = {}
        self.declined: set[str] = set()
        self.ack: tuple[str, simpy.Event] | None = None
        self.wake: simpy.Event | None = None
        self.waiting_late = False
        self.process: Any = None


class AuctionHouse:
    """The auctioneer role of one robot (or of the operator)."""

    def __init__(
        self, owner: str, ports: AuctionPorts, on_allocated: Callable[[Allocation], None]
    ) -> None:
        self.owner = owner
        self.ports = ports
        self._on_allocated = on_allocated
        self.open_auctions: dict[str, AuctionRecord] = {}
        self._live: dict[str, _Live] = {}
        self.allocations: dict[str, Allocation] = {}

    # --- opening and running -------------------------------------------------------------
    def open(
        self,
        task_type: TaskType,
        location: Location,
        task_id: str,
        *,
        kind: str,
        search_path: tuple[Location, ...] = (),
        reauction_of: str | None = None,
    ) -> AuctionRecord:
        for running in self.open_auctions.values():
            if running.task_id == task_id:
                return running  # one auction per task and auctioneer (adoption meets resumption)
        rec = self.ports.new_auction(
            self.owner, kind, task_type, location, task_id, search_path, reauction_of
        )
        self.open_auctions[rec.id] = rec
        live = _Live()
        self._live[rec.id] = live
        live.process = self.ports.env.process(self._run(rec, live))
        return rec

    def _announce(self, rec: AuctionRecord) -> None:
        self.ports.publish(
            Announce(
                sender=self.owner,
                auction_id=rec.id,
                auctioneer=self.owner,
                task_type=rec.task_type,
                location=rec.location,
                task_id=rec.task_id,
                opened_at=rec.opened_at,
                round=rec.round,
                search_path=rec.search_path,
            )
        )

    def _run(self, rec: AuctionRecord, live: _Live) -> Any:
        env, proto = self.ports.env, self.ports.protocol
        try:
            self._announce(rec)
            yield env.timeout(proto.bid_window_s)
            while True:
                for winner in self._ranked(rec, live):
                    ack = env.event()
                    live.ack = (winner, ack)
                    rec.awards.append(AwardRecord(env.now, winner))
                    self.ports.emit("auction_awarded", auction_id=rec.id, winner=winner)
                    self.ports.publish(
                        Award(
                            sender=self.owner,
                            auction_id=rec.id,
                            auctioneer=self.owner,
                            task_type=rec.task_type,
                            location=rec.location,
                            winner=winner,
                        )
                    )
                    yield ack | env.timeout(proto.ack_timeout_s)
                    live.ack = None
                    if ack.triggered and ack.value is True:
                        rec.awards[-1].outcome = "accepted"
                        self._close(rec, winner)
                        return
                    outcome = "declined" if ack.triggered else "timeout"
                    rec.awards[-1].outcome = outcome
                    self.ports.note_decline(rec, winner, outcome)
                    live.declined.add(winner)
                    break  # re-rank: bids may have changed while we waited
                else:
                    # Nobody can take it now: wait for a late finite bid or the retry interval.
                    live.wake = env.event()
                    live.waiting_late = True
                    result = yield live.wake | env.timeout(proto.retry_s)
                    live.waiting_late = False
                    if live.wake not in result:
                        rec.round += 1
                        rec.reannouncements += 1
                        live.live_bids.clear()
                        live.declined.clear()
                        self.ports.emit("auction_reannounced", auction_id=rec.id, round=rec.round)
                        self._announce(rec)
                        yield env.timeout(proto.bid_window_s)
        except simpy.Interrupt:
            return

    def _publish_close(
        self, rec: AuctionRecord, winner: str | None, status: Literal["closed", "cancelled"]
    ) -> None:
        self.ports.publish(
            Close(
                sender=self.owner,
                auction_id=rec.id,
                auctioneer=self.owner,
                task_type=rec.task_type,
                location=rec.location,
                task_id=rec.task_id,
                allocated_to=winner,
                status=status,
            )
        )
        self.ports.close_auction(rec, status, winner)

    def _ranked(self, rec: AuctionRecord, live: _Live) -> list[str]:
        """Award order: the bids ranked (docs/spec.md §6.4), or the policy's oracle's choice."""
        chosen = self.ports.oracle_rank(rec, live.live_bids, live.declined)
        if chosen is not None:
            return chosen
        return rank_bids(
            live.live_bids, live.declined, lambda tied: self.ports.break_tie(rec, tied)
        )

    def _close(self, rec: AuctionRecord, winner: str) -> None:
        self._publish_close(rec, winner, "closed")
        self.open_auctions.pop(rec.id, None)
        self._live.pop(rec.id, None)
        alloc = Allocation(
            rec.id, rec.task_id, rec.task_type, rec.location, winner, self.ports.env.now
        )
        alloc.search_path = rec.search_path
        self.allocations[rec.task_id] = alloc
        self._on_allocated(alloc)

    def cancel(self, auction_id: str) -> None:
        rec = self.open_auctions.pop(auction_id, None)
        live = self._live.pop(auction_id, None)
        if rec is None:
            return
        if live is not None and live.process is not None and live.process.is_alive:
            live.process.interrupt("cancelled")
        self._publish_close(rec, None, "cancelled")

    # --- incoming messages ---------------------------------------------------------------
    def on_bid(self, msg: Bid) -> None:
        rec = self.open_auctions.get(msg.auction_id)
        live = self._live.get(msg.auction_id)
        if rec is None or live is None or msg.round != rec.round:
            return
        rec.bids.append(BidRecord(self.ports.env.now, msg.bidder, msg.utility, msg.round))
        live.live_bids[msg.bidder] = msg.utility
        if math.isfinite(msg.utility):
            live.declined.discard(msg.bidder)
            if live.waiting_late and live.wake is not None and not live.wake.triggered:
                live.wake.succeed()

    def on_ack(self, msg: Ack) -> None:
        live = self._live.get(msg.auction_id)
        if live is None or live.ack is None:
            return
        winner, ev = live.ack
        if winner == msg.winner and not ev.triggered:
            ev.succeed(msg.accepted)

    def reannounce_open(self) -> None:
        """Tell a newcomer about every auction still open (answers Hello)."""
        for rec in self.open_auctions.values():
            self._announce(rec)

    def stop(self) -> Duties:
        """The owner failed: its auctions stop where they are. What it was responsible for is
        returned, for the owner to resume if it comes back and no peer took it over."""
        for live in self._live.values():
            if live.process is not None and live.process.is_alive:
                live.process.interrupt("auctioneer down")
        duties = Duties(list(self.open_auctions.values()), dict(self.allocations))
        self._live.clear()
        self.open_auctions.clear()
        self.allocations.clear()
        return duties

    def resume(self, duties: Duties) -> None:
        """Take up an earlier life's duties: its auctions again (as re-auctions), its watches."""
        for rec in duties.auctions:
            if rec.task_id not in self.allocations:
                self.open(
                    rec.task_type,
                    rec.location,
                    rec.task_id,
                    kind=rec.kind,
                    search_path=rec.search_path,
                    reauction_of=rec.id,
                )
        for tid, alloc in duties.watches.items():
            if tid not in self.allocations and not any(
                r.task_id == tid for r in self.open_auctions.values()
            ):
                alloc.since = float(self.ports.env.now)
                self.allocations[tid] = alloc
