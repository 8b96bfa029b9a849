"""What every robot does: move, listen, bid, accept, keep its peers' liveness, fail and return.

A robot knows only what reached it on the bus and what it senses where it stands. Its
behaviour (scan, dig, haul) lives in a subclass as a simpy process; the protocol roles
(bidder here, auctioneer in `AuctionHouse`) are shared.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import simpy

from engine.auction_house import AuctionHouse
from engine.auction_rules import Allocation, Duties
from engine.geometry import Point, path_length, point_along, remaining_path
from engine.messages import (
    Ack,
    Announce,
    Award,
    Bid,
    Close,
    Handoff,
    Hello,
    Holding,
    Leaving,
    Message,
    Probe,
    Revoke,
    Takeover,
    TaskDone,
    TaskType,
)
from engine.planning import Path
from engine.policies import OpenAuction, PendingAward, coalition_partner
from engine.robots.bidder import Bidder
from engine.robots.recovery import Recovery

if TYPE_CHECKING:
    from engine.context import MissionContext

DONE_MEMORY = 8
"""How many finished task ids a heartbeat repeats, for auctioneers that missed a TaskDone."""


@dataclass(frozen=True, slots=True)
class Assignment:
    """A task this robot won and was confirmed for."""

    auction_id: str
    auctioneer: str
    task_type: TaskType
    task_id: str
    location: Point
    search_path: tuple[Point, ...] = ()


@dataclass(slots=True)
class Motion:
    t0: float
    path: Path
    length: float
    speed: float


class Robot(Bidder, Recovery):
    rtype = "robot"
    capability: TaskType | None = None

    def __init__(self, name: str, ctx: MissionContext, pos: Point, speed: float) -> None:
        self.name = name
        self.ctx = ctx
        self.env = ctx.env
        self.pos = pos
        self.heading = 0.0
        self.speed = speed
        self.state = "idle"
        self.alive = True
        self.enabled = True
        self.leaving = False
        self.distance = 0.0
        self.motion: Motion | None = None
        self.partner = coalition_partner(name)  # Policy 2's pairing rule, fixed by the name
        self.house = AuctionHouse(name, ctx, self._on_allocated)
        self.current: Assignment | None = None
        self.queue: deque[Assignment] = deque()
        self._procs: list[Any] = []
        self._wake_event: simpy.Event | None = None
        self._wake_pending = False
        self._life_proc: Any = None
        self._probing: set[str] = set()
        # Memory that survives a failure: what others were responsible for (for adoption),
        # whose duties I took over, tasks I finished, and my own duties while I am down.
        self.peer_open: dict[str, dict[str, OpenAuction]] = {}
        self.peer_alloc: dict[str, dict[str, Allocation]] = {}
        self.adopted: dict[str, list[str]] = {}  # failed peer -> auction ids I opened for it
        self.adopted_tasks: dict[str, tuple[str, ...]] = {}  # failed peer -> its tasks I hold
        self.adopted_cells: dict[str, tuple[int, ...]] = {}  # failed peer -> its cells I scan
        self.done_ids: deque[str] = deque(maxlen=DONE_MEMORY)
        self.completed: set[str] = set()  # tasks I finished for good
        self.peers = {name: self.rtype}  # name -> type, from the roster, Hello and heartbeats
        self.dormant = Duties()
        self.rejoining = False
        self.taken_back: set[str] = set()  # my tasks a peer took over while I was down
        self._reset_knowledge()
        ctx.liveness.add(name)
        ctx.bus.subscribe(name, self.on_message)

    def _reset_knowledge(self) -> None:
        self.open_auctions: dict[str, OpenAuction] = {}  # the ones I can serve
        self.rounds: dict[str, int] = {}  # latest round heard of every announced auction
        self._in_order: list[OpenAuction] | None = None  # open_auctions by opening order
        self.my_bids: dict[str, tuple[int, float]] = {}
        self._bid_situation: tuple[object, ...] = ()  # what my time bids were computed from
        self.reserved: OpenAuction | None = None
        self.pending_awards: list[PendingAward] = []
        self.down: set[str] = set()
        self.down_at: dict[str, float] = {}

    # --- lifecycle ----------------------------------------------------------------------
    def start(self, joined_late: bool = False) -> None:
        self._life_proc = self.env.process(self._life_guarded())
        self._procs.append(self._life_proc)
        self._spawn(self._tick())
        if joined_late:
            self.ctx.bus.publish(
                Hello(sender=self.name, rtype=self.rtype, wants_work=self.wants_work())
            )

    def wants_work(self) -> bool:
        """Hook: a scout with nothing to scan asks for a share of the search."""
        return False

    def _spawn(self, gen: Any) -> None:
        """Run a side process of this robot; it ends quietly when the robot fails."""
        if len(self._procs) > 32:
            self._procs = [p for p in self._procs if p.is_alive]
        self._procs.append(self.env.process(_until_interrupted(gen)))

    def _life_guarded(self) -> Any:
        while True:
            try:
                yield from self.life()
                return
            except simpy.Interrupt as irq:
                if irq.cause != "revoked" or not self.alive:
                    return
                self._end_motion()  # the task was taken back: stop and look again
                self.on_revoked()

    def life(self) -> Any:
        """Work through the tasks won, one at a time; between them, what a free robot does."""
        while True:
            if self.leaving:
                self.go_quiet()
                return
            if self.queue:
                self.current = self.queue.popleft()
                yield from self.work(self.current)
            else:
                yield from self.when_free()

    def work(self, a: Assignment) -> Any:
        """Carry out one won task; robots that win tasks override it."""
        raise NotImplementedError(f"{self.rtype} cannot carry out {a.task_type}")
        yield  # pragma: no cover - makes this a generator

    def when_free(self) -> Any:
        """Nothing to do: wait until something changes."""
        self.state = "idle"
        yield self.wait_for_wake()

    def on_revoked(self) -> None:
        """Hook: tidy up after the current task was revoked mid-way."""
        self.current = None
        self.consider_bids()

    def _tick(self) -> Any:
        proto = self.ctx.scenario.protocol
        offset = (self.ctx.liveness.index[self.name] % 10) * proto.heartbeat_s / 10
        try:
            yield self.env.timeout(offset)
            while True:
                self.heartbeat()
                self.check_peers()
                yield self.env.timeout(proto.heartbeat_s)
        except simpy.Interrupt:
            return

    @property
    def participating(self) -> bool:
        return self.alive and self.enabled and not self.leaving

    def wake(self) -> None:
        """Nudge the behaviour to look at its situation again (a wake is never lost)."""
        ev = self._wake_event
        if ev is not None and not ev.triggered:
            ev.succeed()
        else:
            self._wake_pending = True

    def wait_for_wake(self) -> simpy.Event:
        ev = self.env.event()
        if self._wake_pending:
            self._wake_pending = False
            ev.succeed()
        self._wake_event = ev
        return ev

    # --- motion -------------------------------------------------------------------------
    def position(self, t: float | None = None) -> tuple[Point, float]:
        m = self.motion
        if m is None:
            return self.pos, self.heading
        t = self.env.now if t is None else t
        return point_along(m.path, min(m.length, max(0.0, (t - m.t0) * m.speed)))

    def remaining_route(self) -> list[Point]:
        m = self.motion
        if m is None:
            return []
        return remaining_path(m.path, min(m.length, (self.env.now - m.t0) * m.speed))

    def drive(self, path: Path, report: bool = False) -> Any:
        """Drive along a path at this robot's speed; interruptible only by failure. With
        `report`, a heartbeat goes out as it sets off, saying where it is going (a hauler with
        a mineral: if it fails on the way, its watcher searches that very route)."""
        length = path_length(path)
        if length <= 0.0:
            self.pos = path[-1]
            return
        self.motion = Motion(float(self.env.now), path, length, self.speed)
        if report:
            self.heartbeat()
        yield self.env.timeout(length / self.speed)
        self._end_motion(length)

    def _end_motion(self, travelled: float | None = None) -> None:
        m = self.motion
        if m is None:
            return
        if travelled is None:
            travelled = min(m.length, (self.env.now - m.t0) * m.speed)
        self.pos, self.heading = point_along(m.path, travelled)
        self.distance += travelled
        self.motion = None

    def go_to(self, goal: Point) -> Any:
        yield from self.drive(self.ctx.planner.plan(self.pos, goal))

    # --- messages -----------------------------------------------------------------------
    def on_message(self, msg: Message) -> None:
        if not self.alive:
            return
        handler = _HANDLERS.get(type(msg))
        if handler is not None:
            handler(self, msg)

    def _on_announce(self, msg: Announce) -> None:
        if msg.task_id in self.completed:
            # offered again from an old record (a watcher back from a failure that missed my
            # TaskDone): it is done, say so again and the auctioneer withdraws it
            self.ctx.bus.publish(
                TaskDone(
                    sender=self.name, auction_id=msg.auction_id, task_id=msg.task_id, outcome="done"
                )
            )
            return
        if any(a.task_id == msg.task_id for a in self.tasks_held()):
            self.ctx.bus.publish(
                Holding(sender=self.name, task_id=msg.task_id, auction_id=msg.auction_id)
            )
            return
        if msg.auction_id in self.rounds:  # a re-announcement: only the round is new
            self.rounds[msg.auction_id] = msg.round
            if msg.auction_id in self.open_auctions:
                self.consider_bids()
            return
        self.rounds[msg.auction_id] = msg.round
        info = OpenAuction(
            msg.auction_id,
            msg.auctioneer,
            msg.task_type,
            msg.location,
            msg.task_id,
            msg.opened_at,
            msg.search_path,
        )
        if self.peer_type(msg.sender) == self.rtype:
            self.peer_open.setdefault(msg.sender, {})[msg.auction_id] = info
        # a duplicate auction for a task I am auctioning: the smaller name keeps it
        for rec in list(self.house.open_auctions.values()):
            if rec.task_id == msg.task_id and rec.id != msg.auction_id and msg.sender < self.name:
                self.house.cancel(rec.id)
        self.on_task_heard(info)
        if msg.task_type == self.capability:
            self.open_auctions[msg.auction_id] = info
            self._in_order = None
            self.consider_bids()

    def forget_auction(self, auction_id: str) -> OpenAuction | None:
        self.rounds.pop(auction_id, None)
        info = self.open_auctions.pop(auction_id, None)
        if info is not None:
            self._in_order = None
        return info

    def auctions_in_order(self) -> list[OpenAuction]:
        """Open auctions I can serve, by opening order, minus those of auctioneers I think down."""
        if self._in_order is None:
            self._in_order = sorted(
                (a for a in self.open_auctions.values() if a.auctioneer not in self.down),
                key=lambda a: a.order,
            )
        return self._in_order

    def peer_type(self, name: str) -> str | None:
        """What a peer is, as far as messages have told me (None: never heard of it)."""
        rtype = self.peers.get(name)
        if rtype is None:
            hb = self.ctx.liveness.last_heartbeat(self.name, name)
            if hb is not None:
                rtype = self.peers[name] = hb.rtype
        return rtype

    def peers_of_type(self, rtype: str) -> list[str]:
        """Every robot of this type I know of, me included, by name."""
        for name in self.ctx.liveness.names:  # the senders whose heartbeats reach me
            self.peer_type(name)
        return sorted(n for n, t in self.peers.items() if t == rtype)

    def on_task_heard(self, info: OpenAuction) -> None:
        """Hook: any announcement (scouts learn of sites their peers found)."""

    def _on_bid(self, msg: Bid) -> None:
        if msg.auctioneer == self.name:
            self.house.on_bid(msg)

    def _on_ack(self, msg: Ack) -> None:
        if msg.auctioneer == self.name:
            self.house.on_ack(msg)

    def _on_close(self, msg: Close) -> None:
        info = self.forget_auction(msg.auction_id)
        self.my_bids.pop(msg.auction_id, None)
        peer = self.peer_open.get(msg.sender)
        if peer is not None:
            peer.pop(msg.auction_id, None)
            if msg.allocated_to is not None:
                self.peer_alloc.setdefault(msg.sender, {})[msg.task_id] = Allocation(
                    msg.auction_id,
                    msg.task_id,
                    msg.task_type,
                    msg.location,
                    msg.allocated_to,
                    float(self.env.now),
                )
        self.on_close_heard(msg)
        if self.reserved is not None and self.reserved.auction_id == msg.auction_id:
            reserved, self.reserved = self.reserved, None
            if msg.allocated_to == self.name and self.alive:
                self.assign(
                    Assignment(
                        reserved.auction_id,
                        reserved.auctioneer,
                        reserved.task_type,
                        reserved.task_id,
                        reserved.location,
                        reserved.search_path,
                    )
                )
        elif info is not None or msg.allocated_to is not None:
            self.consider_bids()

    def on_close_heard(self, msg: Close) -> None:
        """Hook: subclasses track what others were allocated (coalition partners)."""

    def _on_task_done(self, msg: TaskDone) -> None:
        for allocs in self.peer_alloc.values():
            allocs.pop(msg.task_id, None)
        alloc = self.house.allocations.pop(msg.task_id, None)
        if alloc is not None and msg.outcome == "released":
            self.reauction(alloc, None)
        elif msg.outcome == "done":
            for rec in list(self.house.open_auctions.values()):
                if rec.task_id == msg.task_id:
                    self.house.cancel(rec.id)
        self.on_task_done_heard(msg)

    def on_task_done_heard(self, msg: TaskDone) -> None:
        """Hook for subclasses."""

    def _on_hello(self, msg: Hello) -> None:
        self.peers[msg.sender] = msg.rtype
        self.house.reannounce_open()
        self.return_duties(msg.sender)
        self.on_hello_heard(msg)

    def on_hello_heard(self, msg: Hello) -> None:
        """Hook: scouts share their remaining cells with a newcomer."""

    def on_handoff_heard(self, msg: Handoff) -> None:
        """Hook: scouts track who scans which cells."""

    def handoffs_received(self) -> tuple[str, ...]:
        return ()

    # --- tasks --------------------------------------------------------------------------
    def tasks_held(self) -> list[Assignment]:
        """The task I work on and those queued behind it."""
        return ([] if self.current is None else [self.current]) + list(self.queue)

    def assign(self, a: Assignment) -> None:
        self.queue.append(a)
        self.ctx.emit(
            "task_started",
            robot=self.name,
            task_id=a.task_id,
            task_type=a.task_type,
            auction_id=a.auction_id,
        )
        self.wake()

    def finish(self, a: Assignment, outcome: Literal["done", "void", "released"] = "done") -> None:
        self.current = None
        if outcome != "released":  # a released task is not done: its watcher offers it again
            self.done_ids.append(a.task_id)
        if outcome == "done" or (outcome == "void" and a.task_type == "transport"):
            self.completed.add(a.task_id)  # final: no one need ever carry this again
        self.ctx.emit("task_ended", robot=self.name, task_id=a.task_id, outcome=outcome)
        self.ctx.bus.publish(
            TaskDone(sender=self.name, auction_id=a.auction_id, task_id=a.task_id, outcome=outcome)
        )
        self.consider_bids()

    def _on_allocated(self, alloc: Allocation) -> None:
        """Hook from the auction house when one of my auctions closes."""

    # --- operator-driven failures -------------------------------------------------------
    def fail(self) -> None:
        """Abrupt failure: stop where it is; nothing is sent or answered any more."""
        self._end_motion()
        self.alive = False
        self.enabled = False
        self.state = "failed"
        me = self.env.active_process  # a graceful exit runs inside the robot's own process
        for p in self._procs:
            if p.is_alive and p is not me:
                p.interrupt("failed")
        self._procs.clear()
        self.dormant = self.dormant.merge(self.house.stop())
        self.drop_loads()
        self.current = None
        self.queue.clear()

    def drop_loads(self) -> None:
        """Hook: whatever it carries falls where it stands."""

    def disable(self) -> None:
        """Graceful: take nothing new, finish the current hand-over, then say goodbye."""
        self.leaving = True
        self.wake()

    def go_quiet(self) -> None:
        """The end of a graceful disable: announce it, then stop like a failure. Its open
        auctions stay open for the peer that adopts them (cancelling would lose their tasks)."""
        self.ctx.bus.publish(Leaving(sender=self.name, progress=self.progress()))
        self.fail()
        self.state = "disabled"
        self.ctx.emit("robot_quiet", robot=self.name)

    def enable(self) -> None:
        """Back from a failure (a new life): a full peer at once for bidding and working; its
        earlier duties are settled after a listening period (`Recovery.rejoin`)."""
        self.alive = True
        self.enabled = True
        self.leaving = False
        self.state = "idle"
        self.current = None
        self.queue.clear()
        self._reset_knowledge()
        self.house = AuctionHouse(self.name, self.ctx, self._on_allocated)
        self.rejoining = True
        self.taken_back = set()
        self.start(joined_late=True)
        self._spawn(self.rejoin())


def _until_interrupted(gen: Any) -> Any:
    try:
        yield from gen
    except simpy.Interrupt:
        return


_HANDLERS: dict[type[Message], Any] = {
    Announce: Robot._on_announce,
    Bid: Robot._on_bid,
    Award: Robot._on_award,
    Ack: Robot._on_ack,
    Close: Robot._on_close,
    TaskDone: Robot._on_task_done,
    Holding: Robot._on_holding,
    Takeover: Robot._on_takeover,
    Leaving: Robot._on_leaving,
    Hello: Robot._on_hello,
    Handoff: lambda robot, msg: robot.on_handoff_heard(msg),
    Probe: Robot._on_probe,
    Revoke: Robot._on_revoke,
}
