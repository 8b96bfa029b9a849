"""The ideal bus's board of auction rounds: a re-announcement costs what it changes.

An auction nobody could take is announced again every few seconds to its whole audience
(every robot that serves its task type or shares its auctioneer's type). On the ideal bus
they all hear each round at the same instant, and most of them (busy, quiet bidders that
know the auction) would only note the round: at scale 100 that was a quarter of a mission,
hundreds of robots times thousands of rounds. The board notes a round for all of them at
once: a robot's `Rounds` reads an auction's latest round from the board unless the robot
wrote (or kept) its own since. The bus then visits only the robots a round may change
something for, in subscription order, with the same first look and handler as before:

- *strangers*: robots of the audience that do not know the auction (they learn it);
- the *holders* and *finishers* of its task (they answer Holding or TaskDone);
- *attentive* bidders that can serve it: bidders not known to be quiet. Whatever can end a
  bidder's quiet (its auction list, its bids, its tasks, its reservation, its battery, the
  policy, a coalition partner's site) stirs it; a look that finds it quiet settles it. A
  quiet may also have a time (`Policy.no_targets_until`: Policy 2's paired hauler has no
  targets while its partner works, until the partner could be declared silent): the first
  later round from that time stirs it.

Visiting a robot that did not need it changes nothing; missing one would change the run.
With `CHECK` set (tests), every round also asks each robot it did not visit whether the
first look would only have noted the round, and every read of a round is compared with
the round the robot would have noted itself.

Every other bus (lossy, late, ranged) delivers each copy to its robot as before, and a
robot's `Rounds` is then a plain table.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Iterator, Mapping
from typing import Protocol

from engine.messages import Announce

CHECK = False
"""Verify every round the board skips (slow: for tests)."""

_EARLY = 1e-6
"""Seconds before its time a robot quiet until then is stirred (rounding in that time)."""


class _Bidder(Protocol):
    @property
    def biddable(self) -> Mapping[str, object]: ...
    def quiet_until(self) -> float | None: ...


Visit = Callable[[str], None]
OnlyNotes = Callable[[Announce], str | None]
"""A robot's first look without its effect: None if the handler is needed, else why not
("dead", or "note": it would only note the round)."""


class Rounds(Mapping[str, int]):
    """A robot's latest round of every announced auction it knows, read when it bids."""

    __slots__ = ("_board", "_own", "_shadow", "_stamp", "name")

    def __init__(self, name: str, board: RoundBoard | None) -> None:
        self.name = name
        self._board = board
        self._own: dict[str, int] = {}
        self._stamp: dict[str, int] = {}  # the board's count of the auction's rounds then
        self._shadow: dict[str, int] | None = {} if CHECK and board is not None else None

    def __contains__(self, aid: object) -> bool:
        return aid in self._own

    def __getitem__(self, aid: str) -> int:
        value = self.get(aid)
        if value is None:
            raise KeyError(aid)
        return value

    def __iter__(self) -> Iterator[str]:
        return iter(self._own)

    def __len__(self) -> int:
        return len(self._own)

    def get(self, aid: str, default: int | None = None) -> int | None:  # type: ignore[override]
        own = self._own.get(aid)
        if own is None:
            return default
        board = self._board
        if board is not None and self._stamp[aid] < board.seq.get(aid, 0):
            own = board.latest[aid]  # noted on the board while I was not visited
        if self._shadow is not None:
            assert own == self._shadow[aid], (self.name, aid, own, self._shadow[aid])
        return own

    def note(self, aid: str, rnd: int) -> None:
        """I heard this round."""
        new = aid not in self._own
        self._own[aid] = rnd
        board = self._board
        if board is None:
            return
        self._stamp[aid] = board.stamp(aid)
        if self._shadow is not None:
            self._shadow[aid] = rnd
        if new:
            board.learned(self.name, aid)

    def keep(self, aid: str) -> None:
        """I heard a round but my round stays as it was (I hold or finished its task)."""
        board = self._board
        if board is not None and aid in self._own:
            self._own[aid] = self.get(aid)  # type: ignore[assignment]
            self._stamp[aid] = board.stamp(aid)

    def forget(self, aid: str) -> None:
        if self._own.pop(aid, None) is None:
            return
        board = self._board
        if board is not None:
            del self._stamp[aid]
            if self._shadow is not None:
                self._shadow.pop(aid, None)
            board.forgot(self.name, aid)

    def clear(self) -> None:
        """A new life: nothing known."""
        self._own.clear()
        self._stamp.clear()
        if self._shadow is not None:
            self._shadow.clear()
        if self._board is not None:
            self._board.forgot_all(self.name)

    def noted_on_board(self, aid: str, rnd: int) -> None:
        """(CHECK) The board noted this round for me: what I would have noted myself."""
        if self._shadow is not None and aid in self._own:
            self._shadow[aid] = rnd


class RoundBoard:
    """The rounds of the open auctions and who must still hear them (see the module)."""

    def __init__(self) -> None:
        self.seq: dict[str, int] = {}  # auction -> its deliveries so far
        self.latest: dict[str, int] = {}  # auction -> its latest round
        self._open: dict[str, tuple[str, str, str]] = {}  # -> (task type, sender, its type)
        self._strangers: dict[str, set[str]] = {}
        self._attentive: set[str] = set()
        self._holders: dict[str, set[str]] = {}  # task -> robots that hold it
        self._finishers: dict[str, set[str]] = {}  # task -> robots that finished it
        self._held: dict[str, frozenset[str]] = {}
        self._order: dict[str, int] = {}  # subscription order
        self._member: dict[str, tuple[str, frozenset[str] | None]] = {}  # (type, hears)
        self._rounds: dict[str, Rounds] = {}
        self._bidders: dict[str, _Bidder | None] = {}
        self._only_notes: dict[str, OnlyNotes] = {}
        self._delivering: str | None = None
        self._stirred: list[str] = []  # robots stirred while a round is delivered
        self._wakes: list[tuple[float, int, str]] = []  # (time, order, robot): quiet until then
        self._wake_at: dict[str, float] = {}  # each robot's latest such time

    # --- the robots -----------------------------------------------------------------------
    def join(
        self,
        name: str,
        rtype: str,
        hears: frozenset[str] | None,
        rounds: Rounds,
        only_notes: OnlyNotes,
    ) -> None:
        """A robot subscribed (again): a stranger to every open auction it can hear."""
        self._order.setdefault(name, len(self._order))
        self._member[name] = (rtype, hears)
        self._rounds[name] = rounds
        self._only_notes[name] = only_notes
        self._bidders.setdefault(name, None)
        self.forgot_all(name)
        self.stir(name)

    def bidder(self, name: str, bidder: _Bidder | None) -> None:
        self._bidders[name] = bidder
        self.stir(name)

    def _hears(self, name: str, aid: str) -> bool:
        rtype, hears = self._member[name]
        task_type, _, sender_type = self._open[aid]
        return hears is None or task_type in hears or rtype == sender_type

    def stir(self, name: str) -> None:
        """Something that can end this robot's quiet changed."""
        if name not in self._attentive:
            self._attentive.add(name)
            if self._delivering is not None:
                self._stirred.append(name)

    def stir_all(self) -> None:
        for name in self._order:
            self.stir(name)

    def settle(self, name: str) -> None:
        """The robot's bidder found itself quiet: until stirred, or until a time (it is
        stirred then: `_wake_due`)."""
        bidder = self._bidders.get(name)
        until = math.inf if bidder is None else bidder.quiet_until()
        if until is None:
            return
        self._attentive.discard(name)
        if until < math.inf:
            self._wake_at[name] = until
            heapq.heappush(self._wakes, (until, self._order[name], name))

    def _wake_due(self, now: float) -> None:
        """Stir the robots whose quiet had a time that has come (a little early: a visit
        that finds a robot still quiet changes nothing, while a late one would miss a bid)."""
        wakes = self._wakes
        while wakes and wakes[0][0] <= now + _EARLY:
            until, _, name = heapq.heappop(wakes)
            if self._wake_at.get(name) == until:
                del self._wake_at[name]
                self.stir(name)

    def held(self, name: str, tasks: frozenset[str]) -> None:
        """The tasks this robot holds now (current and queued)."""
        old = self._held.get(name, frozenset())
        if tasks != old:
            for t in old - tasks:
                self._holders[t].discard(name)
            for t in tasks - old:
                self._holders.setdefault(t, set()).add(name)
            self._held[name] = tasks
        self.stir(name)

    def finished(self, name: str, task_id: str) -> None:
        self._finishers.setdefault(task_id, set()).add(name)
        if self._delivering is not None:
            self._stirred.append(name)

    # --- what the robots' rounds tell it ------------------------------------------------------
    def stamp(self, aid: str) -> int:
        """The count of the auction's rounds a write now belongs to (the one being delivered)."""
        return self.seq.get(aid, 0) + (self._delivering == aid)

    def learned(self, name: str, aid: str) -> None:
        strangers = self._strangers.get(aid)
        if strangers is not None:
            strangers.discard(name)

    def forgot(self, name: str, aid: str) -> None:
        if aid in self._open:
            self._strangers[aid].add(name)
            if self._delivering is not None:
                self._stirred.append(name)

    def forgot_all(self, name: str) -> None:
        for aid in self._open:
            if self._hears(name, aid):
                self._strangers[aid].add(name)
        if self._delivering is not None:
            self._stirred.append(name)

    # --- delivering ---------------------------------------------------------------------------
    def sparse(self, msg: Announce) -> bool:
        """Can this announcement go to the robots it may change something for alone? A later
        round of an auction the board has seen opened by the same sender."""
        known = self._open.get(msg.auction_id)
        return bool(msg.round) and known is not None and known[1] == msg.sender

    def deliver_all(self, msg: Announce, audience: list[str], visit: Visit) -> None:
        """Every robot of the audience hears it (a first announcement, or one the board has
        not seen): the board learns who still does not know the auction."""
        aid = msg.auction_id
        self._delivering = aid
        try:
            for name in audience:
                visit(name)
        finally:
            self._delivering = None
            self._stirred.clear()
        rounds = self._rounds
        self._strangers[aid] = {n for n in audience if aid not in rounds[n]}
        self._open[aid] = (msg.task_type, msg.sender, self._member.get(msg.sender, ("", None))[0])
        self._delivered(msg)

    def deliver_sparse(
        self, msg: Announce, audience: frozenset[str], visit: Visit, now: float
    ) -> None:
        """A later round: visits the strangers, the task's holders and finishers and the
        attentive bidders that can serve it, in subscription order; notes it for the rest."""
        self._wake_due(now)
        aid, task_id = msg.auction_id, msg.task_id
        bidders, order = self._bidders, self._order
        due = set(self._strangers[aid])
        due.update(self._holders.get(task_id, ()))
        due.update(self._finishers.get(task_id, ()))
        for name in self._attentive & audience:
            bidder = bidders[name]
            if bidder is not None and aid in bidder.biddable:
                due.add(name)
        due.discard(msg.sender)
        due &= audience
        heap = [(order[n], n) for n in due]
        heapq.heapify(heap)
        skipped = sorted(audience - due - {msg.sender}, key=order.__getitem__) if CHECK else []
        self._delivering = aid
        try:
            while heap:
                at, name = heapq.heappop(heap)
                if CHECK:
                    skipped = self._check_skipped(msg, skipped, at, due)
                visit(name)
                self._settle_after(name)
                if self._stirred:
                    for late in self._stirred:
                        if late in audience and late not in due and order[late] > at:
                            due.add(late)
                            heapq.heappush(heap, (order[late], late))
                    self._stirred.clear()
            if CHECK:
                self._check_skipped(msg, skipped, len(order), due)
        finally:
            self._delivering = None
            self._stirred.clear()
        self._delivered(msg)

    def _settle_after(self, name: str) -> None:
        if name in self._attentive:
            self.settle(name)

    def _delivered(self, msg: Announce) -> None:
        aid = msg.auction_id
        self.seq[aid] = self.seq.get(aid, 0) + 1
        self.latest[aid] = msg.round

    def closed(self, aid: str) -> None:
        """The auction's Close was heard by everyone: its rounds are read no more."""
        if self._open.pop(aid, None) is not None:
            del self._strangers[aid]
        self.seq.pop(aid, None)
        self.latest.pop(aid, None)

    def _check_skipped(
        self, msg: Announce, skipped: list[str], before: int, due: set[str]
    ) -> list[str]:
        """(CHECK) The robots skipped ahead of subscription place `before` would only have
        noted the round; the board notes it for them."""
        order, k = self._order, 0
        while k < len(skipped) and order[skipped[k]] < before:
            name = skipped[k]
            k += 1
            if name in due:  # stirred during this delivery: visited after all
                continue
            why = self._only_notes[name](msg)
            assert why is not None, f"{name} skipped but must hear {msg.auction_id}"
            if why == "note":
                self._rounds[name].noted_on_board(msg.auction_id, msg.round)
        return skipped[k:]
