"""The Zenoh side of field mode: opening a peer session, the fault injector, and the bus.

`ZenohBus` implements the engine's `Bus` interface (`engine.bus.Bus`) for the one robot an
agent process runs: `publish` puts the message on the network, and what arrives from the
network waits in an inbox until the agent's clock loop hands it to the robot (robots are not
thread-safe; Zenoh calls back on its own threads).
"""

from __future__ import annotations

import heapq
import itertools
import json
import logging
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
import zenoh

from engine.liveness import Liveness
from engine.messages import (
    Ack,
    Announce,
    Award,
    Bid,
    Close,
    Handoff,
    Heartbeat,
    Hello,
    Message,
    PolicyChange,
)
from field.drain import Drain
from field.link import Link
from field.trust import MAX_REPORT, Rejected
from field.wire import decode, encode, messages_selector

log = logging.getLogger("regolith.field.transport")
Handler = Callable[[Message], None]
FirstLook = Callable[[Announce], bool]


def open_session(listen: str | None = None, connect: str | None = None) -> zenoh.Session:
    """A peer-mode session (no router daemon): listen on an endpoint, connect to one, or
    both. Multicast scouting is off, so sessions meet only where they are told to."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    # Zenoh takes in messages of up to 1 GB by default; nothing honest is over a report's
    # cap, and what waits to be checked (`field.drain`) is bounded by count x this size
    # (a little over the cap is still taken in, so the checks count it as oversized)
    conf.insert_json5("transport/link/rx/max_message_size", str(4 * MAX_REPORT))
    if listen:
        conf.insert_json5("listen/endpoints", json.dumps([listen]))
    if connect:
        conf.insert_json5("connect/endpoints", json.dumps([connect]))
    return zenoh.open(conf)


@dataclass
class Faults:
    """Loss and latency injected around publishers and subscribers (tests, fault studies),
    on top of whatever the network does. Drawn from its own seeded generator."""

    loss: float = 0.0
    latency_s: float = 0.0  # wall seconds
    jitter_s: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0.0 <= self.loss <= 0.9:
            raise ValueError("loss: must lie in 0..0.9")
        if self.latency_s < 0 or self.jitter_s < 0:
            raise ValueError("latency and jitter: must be >= 0")
        self._rng = np.random.default_rng(self.seed)
        self._lock = threading.Lock()
        self.dropped = 0

    def draw(self) -> float | None:
        """None: this message is lost; else its extra delay in wall seconds."""
        with self._lock:
            if self.loss and self._rng.random() < self.loss:
                self.dropped += 1
                return None
            return self.latency_s + (self.jitter_s * self._rng.random() if self.jitter_s else 0.0)


@dataclass
class Stalls:
    """Injected CPU starvation (tests): now and then, after a random wait of `every_s` wall
    seconds on average, an agent stops for `for_s` seconds, holding its robot, as a process
    the scheduler does not run. Drawn from its own seeded generator."""

    for_s: float
    every_s: float
    seed: int = 0

    def __post_init__(self) -> None:
        if self.for_s <= 0 or self.every_s <= 0:
            raise ValueError("stall: both durations must be > 0 (FOR@EVERY, in seconds)")
        self._rng = np.random.default_rng(self.seed)
        self.due = time.monotonic() + self.wait()

    def wait(self) -> float:
        return float(self._rng.exponential(self.every_s))

    def take(self) -> None:
        """Stall now if one is due (the caller holds what a starved process would hold)."""
        if time.monotonic() >= self.due:
            time.sleep(self.for_s)
            self.due = time.monotonic() + self.wait()

    @classmethod
    def parse(cls, text: str, seed: int = 0) -> Stalls:
        """`FOR@EVERY` (seconds), e.g. `0.5@4`."""
        try:
            for_s, every_s = (float(x) for x in text.split("@"))
        except ValueError:
            raise ValueError(f"stall: {text!r} is not FOR@EVERY (seconds, e.g. 0.5@4)") from None
        return cls(for_s, every_s, seed)

    def __str__(self) -> str:
        return f"{self.for_s:g}@{self.every_s:g}"


class Inbox:
    """Messages heard from the network, each due at a wall time (now, or later under an
    injected latency); thread-safe. `ready` is set whenever something arrives."""

    def __init__(self) -> None:
        self._heap: list[tuple[float, int, Message]] = []
        self._serial = itertools.count()
        self._lock = threading.Lock()
        self.ready = threading.Event()

    def put(self, msg: Message, delay_s: float = 0.0) -> None:
        with self._lock:
            heapq.heappush(self._heap, (time.monotonic() + delay_s, next(self._serial), msg))
        self.ready.set()

    def due(self, limit: int | None = None) -> list[Message]:
        """What is due now, in order of arrival; at most `limit` (the rest stays due)."""
        now = time.monotonic()
        out: list[Message] = []
        with self._lock:
            while self._heap and self._heap[0][0] <= now and (limit is None or len(out) < limit):
                out.append(heapq.heappop(self._heap)[2])
        return out

    def next_due_in(self) -> float | None:
        with self._lock:
            return None if not self._heap else max(0.0, self._heap[0][0] - time.monotonic())


def may_send(msg: Message, role: str) -> bool:
    """What a robot of `role` may say on the bus beyond speaking in its own name: an
    auction's announcement, award and close only of its own auctions, a bid and an
    acknowledgement only as the bidder, heartbeats and hellos of its own type, search cells
    handed over only by scouts, and never a policy change (mission control commands it)."""
    if isinstance(msg, Announce | Award | Close):
        return msg.auctioneer == msg.sender and msg.auction_id.startswith(f"{msg.sender}/")
    if isinstance(msg, Bid):
        return msg.bidder == msg.sender
    if isinstance(msg, Ack):
        return msg.winner == msg.sender
    if isinstance(msg, Heartbeat | Hello):
        return msg.rtype == role
    if isinstance(msg, Handoff):
        return role == "scout"
    return not isinstance(msg, PolicyChange)


def open_message(link: Link, key: str, payload: bytes) -> Message | None:
    """A protocol message heard on `key`, checked: signed by a member of the mission, in
    its own name, and one its role may send. None (counted) otherwise."""
    opened = link.opener.admit(key, payload)
    if opened is None:
        return None
    msg = decode(opened.body, link.mission)
    if msg is None:
        link.opener.rejections.count(Rejected("malformed", opened.sender, "not a message"))
    elif msg.sender != opened.sender or not key.endswith(f"/{opened.sender}"):
        link.opener.rejections.count(Rejected("impersonation", opened.sender, f"as {msg.sender}"))
    elif not may_send(msg, opened.cert.role):
        link.opener.rejections.count(
            Rejected(
                "not allowed", opened.sender, f"a {type(msg).__name__} from a {opened.cert.role}"
            )
        )
    else:
        return msg
    return None


class ZenohBus:
    """The engine's `Bus` over Zenoh, for one robot (the agent's)."""

    board = None  # each copy really arrives on its own: no board of rounds (the ideal bus's)
    closes_reach_all = False  # a Close can be lost or late: bidders look for missed ones

    def note_unclosed(self, auction_ids: Iterable[str]) -> None:
        """Nothing to keep: bidders here look for missed Closes among every auction."""

    def __init__(
        self,
        link: Link,
        liveness: Liveness,
        on_unknown_peer: Callable[[Message], None] | None = None,
        faults: Faults | None = None,
    ) -> None:
        self._link = link
        self._session = link.session
        self._mission = link.mission
        self._liveness = liveness
        self._faults = faults
        self._on_unknown_peer = on_unknown_peer
        self.inbox = Inbox()
        self.name = ""
        self._handler: Handler | None = None
        self._seq = itertools.count()
        self._publishers: dict[str, Any] = {}
        self.published = 0
        self.received = 0
        self.lost = 0  # by the injector; the network's own losses are not seen
        self._sub = Drain(
            self._session.declare_subscriber,
            messages_selector(self._mission),
            self._on_sample,
            "bus",
        )

    # --- the engine's Bus interface ------------------------------------------------------
    def subscribe(
        self,
        name: str,
        handler: Handler,
        rtype: str = "",
        hears: frozenset[str] | None = None,
        first_look: FirstLook | None = None,
    ) -> None:
        """One robot's bus: every message goes to its handler (`first_look` is a shortcut of
        the simulation's ideal bus; here each copy really arrives on its own)."""
        self.name, self._handler = name, handler

    def publish(self, msg: Message) -> None:
        key, body = encode(self._mission, msg, next(self._seq))
        payload = self._link.sealer.seal(key, body)
        self.published += 1
        if self._faults is not None:
            delay = self._faults.draw()
            if delay is None:
                self.lost += 1
                return
            if delay > 0:
                t = threading.Timer(delay, self._put, (key, payload))
                t.daemon = True
                t.start()
                return
        self._put(key, payload)

    def _put(self, key: str, payload: bytes) -> None:
        pub = self._publishers.get(key)
        if pub is None:
            pub = self._publishers[key] = self._session.declare_publisher(key)
        try:
            pub.put(payload)
        except Exception as exc:  # a closed session at shutdown: nothing to deliver to
            log.debug("put on %s failed: %s", key, exc)

    # --- receiving ------------------------------------------------------------------------
    def _on_sample(self, sample: Any) -> None:
        """Zenoh's thread: check, then queue for the clock loop (never raises)."""
        try:
            msg = open_message(self._link, str(sample.key_expr), sample.payload.to_bytes())
        except Exception:  # pragma: no cover - the checks count and return None by design
            log.exception("dropped a message that could not be checked")
            return
        if msg is None or msg.sender == self.name:
            return
        delay = 0.0
        if self._faults is not None:
            drawn = self._faults.draw()
            if drawn is None:
                self.lost += 1
                return
            delay = drawn
        self.inbox.put(msg, delay)

    def deliver(self, msg: Message, now: float) -> None:
        """The clock loop's thread: the robot hears `msg` at simulation time `now`."""
        board, me = self._liveness, self.name
        self.received += 1
        if msg.sender not in board.index:
            board.add(msg.sender)
            if self._on_unknown_peer is not None:
                self._on_unknown_peer(msg)
        if isinstance(msg, Heartbeat):
            serial = board.record_heartbeat(msg)
            board.deliver_heartbeat(msg.sender, serial, np.array([board.index[me]]), now)
            return  # heartbeats feed the liveness board only, as on the embedded bus
        board.heard_from(me, msg.sender, now)
        to = msg.addressee()
        if to is not None and to != me:
            return
        if self._handler is not None:
            self._handler(msg)

    def close(self) -> None:
        self._sub.undeclare()
