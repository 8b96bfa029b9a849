"""The MURDOCH-variant auction (docs/spec.md §6) over time: first-price, one round, broadcast.

`AuctionHouse` is the auctioneer role any robot (or the operator) plays: it announces,
collects bids for the bid window, awards the best finite bid, moves to the next bidder on a
decline or a silent winner, re-announces after the retry interval when nobody can take the
task, and after the close hands the allocation to its `watches` (`engine.watches`), which
watch the winner until it reports the task done — the house re-auctions it (`reoffer`) if the
winner fails, releases it or drops it. It owns its open auctions and its watches; its robot
asks it through methods (`is_open`, `handles`, `task_done`, `holder_says`, …) and tells it
what it hears. The records it keeps and the decisions it applies are the pure
`engine.auction_rules`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Literal

import simpy

from engine.auction_ports import AuctionPorts
from engine.auction_rules import (
    Allocation,
    AuctionRecord,
    AwardRecord,
    BidRecord,
    Duties,
    rank_bids,
)
from engine.messages import (
    Ack,
    Announce,
    Award,
    Bid,
    Close,
    Heartbeat,
    Location,
    TaskDone,
    TaskType,
)
from engine.watches import Watches


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
    """The auctioneer role of one robot (or of the operator): its open auctions, and the
    tasks it allocated and watches until their winners report them done.

    `kind` is the kind of auction it re-opens for a task whose winner was lost;
    `peer_offers(task_id)` says whether a live peer already offers or watches that task (then
    it is not offered again); `holders_carry`: a task's place moves with its holder (a
    carried mineral, not a site), so a lost one is searched for where the holder was last
    heard."""

    def __init__(
        self,
        owner: str,
        ports: AuctionPorts,
        *,
        kind: str = "operator",
        peer_offers: Callable[[str], bool] = lambda task_id: False,
        holders_carry: bool = True,
    ) -> None:
        self.owner = owner
        self.ports = ports
        self.kind = kind
        self._peer_offers = peer_offers
        self._holders_carry = holders_carry
        self._open: dict[str, AuctionRecord] = {}
        self._live: dict[str, _Live] = {}
        self.watches = Watches(owner, ports, self.reoffer)

    # --- what it holds, asked ------------------------------------------------------------
    def open_ids(self) -> tuple[str, ...]:
        """The ids of its open auctions, in opening order (a heartbeat lists them)."""
        return tuple(self._open)

    def open_records(self) -> list[AuctionRecord]:
        return list(self._open.values())

    def has_open(self, auction_id: str) -> bool:
        return auction_id in self._open

    def is_open(self, task_id: str) -> bool:
        """Is an auction for this task open here?"""
        return any(r.task_id == task_id for r in self._open.values())

    def handles(self, task_id: str) -> bool:
        """Is this task in this house's hands: auctioned here now, or allocated and watched?"""
        return task_id in self.watches or self.is_open(task_id)

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
        for running in self._open.values():
            if running.task_id == task_id:
                return running  # one auction per task and auctioneer (adoption meets resumption)
        rec = self.ports.new_auction(
            self.owner, kind, task_type, location, task_id, search_path, reauction_of
        )
        self._open[rec.id] = rec
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
        self._open.pop(rec.id, None)
        self._live.pop(rec.id, None)
        alloc = Allocation(
            rec.id, rec.task_id, rec.task_type, rec.location, winner, self.ports.env.now
        )
        alloc.search_path = rec.search_path
        self.watches.add(alloc)

    def cancel(self, auction_id: str) -> None:
        rec = self._open.pop(auction_id, None)
        live = self._live.pop(auction_id, None)
        if rec is None:
            return
        if live is not None and live.process is not None and live.process.is_alive:
            live.process.interrupt("cancelled")
        self._publish_close(rec, None, "cancelled")

    def cancel_task(self, task_id: str) -> None:
        """Withdraw the auction for this task, if one is open here."""
        for rec in list(self._open.values()):
            if rec.task_id == task_id:
                self.cancel(rec.id)

    def yield_duplicate(self, auction_id: str, task_id: str, other: str) -> None:
        """`other` announced an auction of its own for a task this house auctions too: the
        smaller name keeps it."""
        for rec in list(self._open.values()):
            if rec.task_id == task_id and rec.id != auction_id and other < self.owner:
                self.cancel(rec.id)

    def drop_adopted(self, auction_ids: list[str]) -> None:
        """A peer with a smaller name adopted the same failed robot: its auctions and watches
        that this house took up for it are let go."""
        for aid in auction_ids:
            self.cancel(aid)
        self.watches.drop_auctions(auction_ids)

    # --- after the close -------------------------------------------------------------------
    def task_done(self, msg: TaskDone) -> None:
        """A TaskDone ends its winner's watch (`Watches.task_done`); a task done needs no
        auction any more."""
        self.watches.task_done(msg)
        if msg.outcome == "done":
            self.cancel_task(msg.task_id)

    def holder_says(self, task_id: str, holder: str) -> None:
        """A robot it re-auctioned a task from is alive and still on it (Holding): it keeps
        the task; a second holder the house allocated it to meanwhile is revoked."""
        for rec in list(self._open.values()):
            if rec.task_id == task_id:
                self.cancel(rec.id)
                self.watches.add(
                    Allocation(
                        rec.id, rec.task_id, rec.task_type, rec.location, holder, self.ports.env.now
                    )
                )
                return
        self.watches.keep_holder(task_id, holder)

    def reoffer(self, alloc: Allocation, hb: Heartbeat | None) -> None:
        """Offer a task again whose holder failed, released it or dropped it (unless a live
        peer already offers or watches it: two watchers back from failures, say). `hb`: what
        the holder said last, if it may tell where a carried mineral went."""
        if self._peer_offers(alloc.task_id):
            return
        if not self._holders_carry:
            hb = None  # a site does not move with its excavator
        location, search = alloc.location, alloc.search_path
        if hb is not None and alloc.task_id not in hb.tasks:
            # back from a failure without it, say: what it last said while it held the task
            hb = self.ports.liveness.last_heartbeat_about(self.owner, alloc.winner, alloc.task_id)
        if hb is not None and hb.load > 0 and hb.tasks[:1] == (alloc.task_id,):
            # it was carrying the mineral: search along its route from where it was last heard
            location, search = (hb.x, hb.y), hb.path
        elif alloc.task_type == "transport" and not search:
            # the mineral may have left the bucket before the hauler fell silent: look at the
            # pick-up point first, then along the road from there to the plant
            search = self.ports.road_to_plant(location)
        self.open(
            alloc.task_type,
            location,
            alloc.task_id,
            kind=self.kind,
            search_path=search,
            reauction_of=alloc.auction_id,
        )

    # --- incoming messages ---------------------------------------------------------------
    def on_bid(self, msg: Bid) -> None:
        rec = self._open.get(msg.auction_id)
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
        for rec in self._open.values():
            self._announce(rec)

    def stop(self) -> Duties:
        """The owner failed: its auctions stop where they are. What it was responsible for is
        returned, for the owner to resume if it comes back and no peer took it over."""
        for live in self._live.values():
            if live.process is not None and live.process.is_alive:
                live.process.interrupt("auctioneer down")
        duties = Duties(list(self._open.values()), self.watches.take())
        self._live.clear()
        self._open.clear()
        return duties

    def give_up(self, records: list[AuctionRecord]) -> None:
        """An earlier life's auctions that a peer took over: superseded (their records would
        otherwise stay open, read by whoever counts the open auctions)."""
        for rec in records:
            if rec.status == "open":
                self.ports.close_auction(rec, "superseded", None)

    def resume(self, duties: Duties) -> None:
        """Take up an earlier life's duties: its auctions again (as re-auctions), its watches."""
        for rec in duties.auctions:
            if rec.task_id not in self.watches:
                self.open(
                    rec.task_type,
                    rec.location,
                    rec.task_id,
                    kind=rec.kind,
                    search_path=rec.search_path,
                    reauction_of=rec.id,
                )
        for tid, alloc in duties.watches.items():
            if not self.handles(tid):
                alloc.since = float(self.ports.env.now)
                self.watches.add(alloc)
