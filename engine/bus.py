"""The broadcast publish/subscribe bus. Every robot hears every message (docs/spec.md §5).

`Bus` is the interface robots use; `EmbeddedBus` delivers in process through the simulation
clock, with seeded loss and latency for fault studies. A middleware bus (e.g. Zenoh) would
implement the same methods and carry `Message.to_dict()` between processes.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any, Protocol

import numpy as np

from engine.liveness import Liveness
from engine.messages import Announce, Close, Heartbeat, Message
from engine.round_board import RoundBoard
from engine.scenario import BusConfig

Handler = Callable[[Message], None]
FirstLook = Callable[[Announce], bool]
"""A subscriber's cheap first look at an announcement on the ideal bus (`EmbeddedBus.subscribe`)."""


class Bus(Protocol):
    board: RoundBoard | None
    """The ideal bus's board of auction rounds (engine/round_board.py); None elsewhere."""

    @property
    def closes_reach_all(self) -> bool:
        """Does every living robot hear every Close the moment it is sent? (Then an auction a
        robot still knows is open, unless it ended without one: `note_unclosed`.)"""
        ...

    def note_unclosed(self, auction_ids: Iterable[str]) -> None:
        """These auctions ended without a Close (their auctioneer failed)."""

    def subscribe(
        self,
        name: str,
        handler: Handler,
        rtype: str = "",
        hears: frozenset[str] | None = None,
        first_look: FirstLook | None = None,
    ) -> None: ...

    def publish(self, msg: Message) -> None: ...


class EmbeddedBus:
    """In-process broadcast. Each receiver independently may lose or delay a message."""

    rounds_on_board = True
    """On the ideal bus, a later round reaches only the robots it may change something for
    (engine/round_board.py); False delivers every round to every robot of its audience."""

    def __init__(
        self,
        env: Any,
        config: BusConfig,
        rng: np.random.Generator,
        on_publish: Callable[[Message], None],
        liveness: Liveness,
    ) -> None:
        self._env = env
        self._liveness = liveness
        self._cfg = config
        self._rng = rng
        self._on_publish = on_publish
        self._subscribers: dict[str, Handler] = {}
        self._rtypes: dict[str, str] = {}
        self._hears: dict[str, frozenset[str] | None] = {}
        self._first_looks: dict[str, FirstLook] = {}
        self._audiences: dict[tuple[str, str], list[tuple[str, Handler]]] = {}
        self._audience_names: dict[tuple[str, str], tuple[list[str], frozenset[str]]] = {}
        self._everyone: list[tuple[str, Handler]] = []
        self.published = 0
        self.lost = 0
        self._ideal = config.loss == 0.0 and config.latency_s == 0.0 and config.jitter_s == 0.0
        self.board = RoundBoard() if self._ideal and self.rounds_on_board else None
        self.unclosed: set[str] = set()  # auctions ended without a Close (`note_unclosed`)

    @property
    def closes_reach_all(self) -> bool:
        """On the ideal bus every living robot hears a Close as it is sent (a robot down then
        forgets all it knew when it comes back), so a bidder looks for missed Closes only among
        the auctions that ended without one (`Bidder.missed_closes`)."""
        return self._ideal

    def note_unclosed(self, auction_ids: Iterable[str]) -> None:
        self.unclosed.update(auction_ids)

    def subscribe(
        self,
        name: str,
        handler: Handler,
        rtype: str = "",
        hears: frozenset[str] | None = None,
        first_look: FirstLook | None = None,
    ) -> None:
        """`hears`: the task types whose announcements this subscriber acts on (None: all);
        it also gets every announcement from a sender of its own `rtype`.

        `first_look`: on the ideal bus, an announcement goes to it before the handler; it
        notes what the subscriber learns (a re-announcement's round) and answers True when
        that is all the handler would have done. Most announcements at scale are rounds of
        auctions nobody could take yet, heard by hundreds of busy robots that only note the
        round: this saves each of them the whole path through the handler."""
        self._subscribers[name] = handler
        self._rtypes[name] = rtype
        self._hears[name] = hears
        if first_look is None:
            self._first_looks.pop(name, None)
        else:
            self._first_looks[name] = first_look
        self._audiences.clear()
        self._audience_names.clear()
        self._everyone = list(self._subscribers.items())  # a new list: never changed in place

    def _audience(self, msg: Announce) -> list[tuple[str, Handler]]:
        """Who an announcement reaches on the ideal bus, in subscription order: every robot
        that can act on it. The others would only note its round, which they never read
        (`Robot._on_announce`); the choice depends on the task type and the sender's type,
        so all rounds of one auction reach the same robots."""
        key = (msg.task_type, self._rtypes.get(msg.sender, ""))
        out = self._audiences.get(key)
        if out is None:
            out = self._audiences[key] = [
                (name, handler)
                for name, handler in self._subscribers.items()
                if (hears := self._hears[name]) is None
                or msg.task_type in hears
                or self._rtypes[name] == key[1]
            ]
        return out

    def _everyone_now(self) -> list[tuple[str, Handler]]:
        """Every subscriber, in subscription order: the list made at the last subscription
        (replaced, never changed in place, so a delivery under way keeps its own)."""
        return self._everyone

    def publish(self, msg: Message) -> None:
        self.published += 1
        self._on_publish(msg)
        if isinstance(msg, Heartbeat):
            self._publish_heartbeat(msg)
            return
        if self._ideal:
            ev = self._env.timeout(0.0)
            ev.callbacks.append(lambda _e: self._deliver_ideal(msg))
            return
        sender = msg.sender
        self._send_lossy(msg, [(n, h) for n, h in self._subscribers.items() if n != sender])

    def _send_lossy(self, msg: Message, receivers: list[tuple[str, Handler]]) -> None:
        """Each receiver's copy is lost with the bus's probability or arrives after its own
        latency and jitter (drawn in the receivers' order, from the bus's stream)."""
        cfg, rng, board = self._cfg, self._rng, self._liveness
        for name, handler in receivers:
            if cfg.loss > 0.0 and rng.random() < cfg.loss:
                self.lost += 1
                continue
            delay = cfg.latency_s + (cfg.jitter_s * rng.random() if cfg.jitter_s else 0.0)
            ev = self._env.timeout(delay)
            ev.callbacks.append(
                lambda _e, n=name, h=handler: _deliver_one(board, n, h, msg, float(_e.env.now))
            )

    def _deliver_ideal(self, msg: Message) -> None:
        """Everyone hears it at once. Everyone learns the sender is alive (one column write);
        a message only one robot acts on is handed to that robot alone (others would ignore it)."""
        self._liveness.heard_everywhere(msg.sender, float(self._env.now))
        to = msg.addressee()
        if to is not None:
            handler = self._subscribers.get(to)
            if handler is not None and to != msg.sender:
                handler(msg)
            return
        sender = msg.sender
        if isinstance(msg, Announce):
            if self.board is not None:
                self._announce_on_board(msg, self.board)
                return
            # round 0 is an auction's first announcement (or its repetition for a newcomer):
            # news to nearly every receiver, so a first look would only say so
            looks = self._first_looks if msg.round else {}
            for name, handler in self._audience(msg):
                if name != sender:
                    look = looks.get(name)
                    if look is None or not look(msg):
                        handler(msg)
            return
        for name, handler in self._everyone_now():
            if name != sender:
                handler(msg)
        if isinstance(msg, Close) and self.board is not None:
            self.board.closed(msg.auction_id)

    def _announce_on_board(self, msg: Announce, board: RoundBoard) -> None:
        """A later round goes to the robots it may change something for (the board notes it
        for the rest); any other announcement to its whole audience."""
        subscribers, looks = self._subscribers, self._first_looks if msg.round else {}

        def visit(name: str) -> None:
            look = looks.get(name)
            if look is None or not look(msg):
                subscribers[name](msg)

        key = (msg.task_type, self._rtypes.get(msg.sender, ""))
        names = self._audience_names.get(key)
        if names is None:
            listed = [n for n, _ in self._audience(msg)]
            names = self._audience_names[key] = (listed, frozenset(listed))
        if board.sparse(msg):
            board.deliver_sparse(msg, names[1], visit, float(self._env.now))
        else:
            board.deliver_all(msg, [n for n in names[0] if n != msg.sender], visit)

    def _publish_heartbeat(self, hb: Heartbeat) -> None:
        board, cfg = self._liveness, self._cfg
        serial = board.record_heartbeat(hb)
        if self._ideal:
            ev = self._env.timeout(0.0)
            ev.callbacks.append(
                lambda _e: board.deliver_heartbeat(hb.sender, serial, None, float(self._env.now))
            )
            return
        sender = board.index[hb.sender]
        receivers = np.arange(len(board.names))
        receivers = receivers[receivers != sender]
        if cfg.loss > 0.0:
            kept = self._rng.random(len(receivers)) >= cfg.loss
            self.lost += int(len(receivers) - kept.sum())
            receivers = receivers[kept]
        delay = cfg.latency_s + (cfg.jitter_s * self._rng.random() if cfg.jitter_s else 0.0)
        ev = self._env.timeout(delay)
        ev.callbacks.append(
            lambda _e: board.deliver_heartbeat(hb.sender, serial, receivers, float(self._env.now))
        )


def _deliver_one(board: Liveness, name: str, handler: Handler, msg: Message, t: float) -> None:
    board.heard_from(name, msg.sender, t)
    handler(msg)
