"""The state every robot keeps and the plumbing its roles share: who and where it is, what it
knows of its peers and their auctions, the tasks it holds, its motion and its processes.

`Robot` is the bidder and the recovery role (`bidder.py`, `recovery.py`) over this core, plus
message handling and the failure life cycle (`base.py`); each role is a subclass of this one
class, so the state is declared once, here, not again in every role.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import dataclass
from operator import attrgetter
from typing import TYPE_CHECKING, Any

import simpy

from engine.auction_house import AuctionHouse
from engine.auction_rules import AUCTION_KINDS, Allocation, Duties
from engine.geometry import Point, path_length, point_along, remaining_path
from engine.messages import Message, TaskType
from engine.planning import Path
from engine.policies import OpenAuction, PendingAward, Policy, coalition_partner

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.energy import Battery

DONE_MEMORY = 8
"""How many finished task ids a heartbeat repeats, for auctioneers that missed a TaskDone."""
_OPENING = attrgetter("order")
"""An open auction's place in opening order (`OpenAuction.order`), as a sort key."""


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


class RobotCore:
    rtype = "robot"
    capability: TaskType | None = None
    hears: frozenset[str] | None = None
    """The task types whose announcements this type acts on: those it can do, those it
    auctions, those a hook reads (None: all). Announcements of other types from robots of
    another type do not reach it on the ideal bus: it would only note their round."""

    def __init__(self, name: str, ctx: MissionContext, pos: Point, speed: float) -> None:
        self.name = name
        self.ctx = ctx
        self.env = ctx.env
        self.pos = pos
        self.heading = 0.0
        self.speed = speed
        self.born_at = float(self.env.now)
        self._state = "idle"
        self._state_since = self.born_at
        self.time_in_state: dict[str, float] = {}  # closed spells only; see `state_times`
        self.alive = True
        self.enabled = True
        self.leaving = False
        self.distance = 0.0
        self.motion: Motion | None = None
        self.partner = coalition_partner(name)  # Policy 2's pairing rule, fixed by the name
        self.house = self._new_house()
        self._every_round = ctx.scenario.protocol.busy_bid == "every_round"
        self._silent_when_busy = ctx.scenario.protocol.busy_bid == "silent"
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
        self._alloc_peers: dict[str, set[str]] = {}  # task id -> peers whose peer_alloc has it
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
        self.battery: Battery | None = (
            None if ctx.energy is None else ctx.energy.battery(self.rtype)
        )
        ctx.liveness.add(name)
        ctx.bus.subscribe(name, self.on_message, self.rtype, self.hears)

    def _new_house(self) -> AuctionHouse:
        """My auctioneer role, for a new life: it offers a lost task again unless a live peer
        of my type already does (`peer_handles`)."""
        return AuctionHouse(
            self.name,
            self.ctx,
            kind=AUCTION_KINDS.get(self.rtype, "operator"),
            peer_offers=self.peer_handles,
            holders_carry=self.rtype != "scout",  # a site does not move with its excavator
        )

    def peer_handles(self, task_id: str) -> bool:
        """Does a live peer of my type run an auction for this task (`Recovery`)?"""
        raise NotImplementedError

    def _reset_knowledge(self) -> None:
        self.open_auctions: dict[str, OpenAuction] = {}  # the ones I can serve
        self.rounds: dict[str, int] = {}  # latest round heard of every announced auction
        self._in_order: list[OpenAuction] | None = None  # open_auctions by opening order
        self.my_bids: dict[str, tuple[int, float]] = {}
        self._refused: bool | None = None  # -inf bid in every auction of _in_order (cache)
        self._quiet_on: list[OpenAuction] | None = None  # busy with nothing to send (`Bidder`)
        self._quiet_policy: Policy | None = None
        self._bid_situation: tuple[object, ...] = ()  # what my time bids were computed from
        self.reserved: OpenAuction | None = None
        self.pending_awards: list[PendingAward] = []
        self.down: set[str] = set()
        self.down_at: dict[str, float] = {}

    @property
    def state(self) -> str:
        """What the robot is doing; every change is timed on the simulation clock."""
        return self._state

    @state.setter
    def state(self, value: str) -> None:
        if value == self._state:
            return
        now = float(self.env.now)
        spent = self.time_in_state.get(self._state, 0.0)
        self.time_in_state[self._state] = spent + (now - self._state_since)
        self._state, self._state_since = value, now
        if self.battery is not None:
            self.energy_changed()

    def energy_changed(self) -> None:
        """The draw on the battery may have changed (state or motion): settle and re-watch."""
        energy = self.ctx.energy
        assert energy is not None
        energy.update(self)

    def state_times(self) -> dict[str, float]:
        """Seconds spent in each state since the robot joined, the current spell up to now
        (they add up to now − born_at)."""
        out = dict(self.time_in_state)
        out[self._state] = out.get(self._state, 0.0) + (float(self.env.now) - self._state_since)
        return out

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
        speed = self.leg_speed()
        self.motion = Motion(float(self.env.now), path, length, speed)
        if self.battery is not None:
            self.energy_changed()
        if report:
            self.heartbeat()
        yield self.env.timeout(length / speed)
        self._end_motion(length)

    def leg_speed(self) -> float:
        """This leg's speed: the nominal one, or a seeded draw under uncertain work."""
        d = self.ctx.durations
        return self.speed if d is None else d.leg_speed(self.speed)

    def work_s(self, mean: float) -> float:
        """How long a piece of work (dig, transfer, unload) of this mean duration takes."""
        d = self.ctx.durations
        return mean if d is None else d.work(mean)

    def _end_motion(self, travelled: float | None = None) -> None:
        m = self.motion
        if m is None:
            return
        if travelled is None:
            travelled = min(m.length, (self.env.now - m.t0) * m.speed)
        self.pos, self.heading = point_along(m.path, travelled)
        self.distance += travelled
        self.motion = None
        if self.battery is not None:
            self.energy_changed()

    def go_to(self, goal: Point) -> Any:
        yield from self.drive(self.ctx.planner.plan(self.pos, goal))

    def _spawn(self, gen: Any) -> None:
        """Run a side process of this robot; it ends quietly when the robot fails."""
        if len(self._procs) > 32:
            self._procs = [p for p in self._procs if p.is_alive]
        self._procs.append(self.env.process(_until_interrupted(gen)))

    # --- what I know --------------------------------------------------------------------
    def note_auction(self, info: OpenAuction) -> None:
        """An auction I can serve opened. Its place in `_in_order` is found by bisection
        rather than by sorting again: hundreds of robots hear each of hundreds of open
        auctions at scale, and a sort per announcement per robot was a tenth of a run."""
        self.open_auctions[info.auction_id] = info
        order = self._in_order
        if order is None or info.auctioneer in self.down:
            return
        order = order.copy()  # a new list: a caller may still hold the old one
        bisect.insort(order, info, key=_OPENING)
        self._in_order = order
        prev = self.my_bids.get(info.auction_id)
        if prev is None or prev[1] != -math.inf:
            self._refused = False

    def forget_auction(self, auction_id: str) -> OpenAuction | None:
        self.rounds.pop(auction_id, None)
        info = self.open_auctions.pop(auction_id, None)
        order = self._in_order
        if info is None or order is None or info.auctioneer in self.down:
            return info
        order = order.copy()
        del order[bisect.bisect_left(order, info.order, key=_OPENING)]  # openings are unique
        self._in_order = order
        if self._refused is False:
            self._refused = None  # the one not refused may be the one gone
        return info

    def auctions_in_order(self) -> list[OpenAuction]:
        """Open auctions I can serve, by opening order, minus those of auctioneers I think down."""
        if self._in_order is None:
            self._refused = None
            self._in_order = sorted(
                (a for a in self.open_auctions.values() if a.auctioneer not in self.down),
                key=_OPENING,
            )
        return self._in_order

    def note_peer_alloc(self, peer: str, alloc: Allocation) -> None:
        """A peer of my type allocated a task (its Close): remembered for adopting its watch."""
        self.peer_alloc.setdefault(peer, {})[alloc.task_id] = alloc
        self._alloc_peers.setdefault(alloc.task_id, set()).add(peer)

    def forget_peer_allocs(self, peer: str) -> dict[str, Allocation]:
        allocs = self.peer_alloc.pop(peer, {})
        for tid in allocs:
            self._unlist(tid, peer)
        return allocs

    def end_peer_alloc(self, task_id: str, winner: str) -> None:
        """`winner` reported the task finished: every peer's allocation of it to `winner` ends
        (found through the task's index, not by a look at every peer)."""
        for peer in list(self._alloc_peers.get(task_id, ())):
            allocs = self.peer_alloc[peer]
            if allocs[task_id].winner == winner:
                del allocs[task_id]
                self._unlist(task_id, peer)

    def _unlist(self, task_id: str, peer: str) -> None:
        peers = self._alloc_peers[task_id]
        peers.discard(peer)
        if not peers:
            del self._alloc_peers[task_id]

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

    def peer_alive(self, name: str) -> bool:
        heard = self.ctx.liveness.last_heard(self.name, name)
        timeout = self.ctx.scenario.protocol.failure_timeout_s
        return name not in self.down and self.env.now - heard <= timeout

    def tasks_held(self) -> list[Assignment]:
        """The task I work on and those queued behind it."""
        return ([] if self.current is None else [self.current]) + list(self.queue)

    # --- hooks the roles and the robot types fill in ------------------------------------
    def progress(self) -> int:
        return 0

    def load(self) -> int:
        return 0

    def handoffs_received(self) -> tuple[str, ...]:
        return ()

    def on_message(self, msg: Message) -> None:
        """Every message the bus brings me (`Robot` dispatches them)."""
        raise NotImplementedError

    def consider_bids(self) -> None:
        """Look at the open auctions again (the bidder role)."""
        raise NotImplementedError

    def heartbeat(self) -> None:
        """Say I am alive and what I hold (the recovery role)."""
        raise NotImplementedError

    def run_dry(self) -> None:
        """The battery is empty: stop where I am, like a failure (`Robot`)."""
        raise NotImplementedError


def _until_interrupted(gen: Any) -> Any:
    try:
        yield from gen
    except simpy.Interrupt:
        return
