"""A robot: its parts, its state, the tasks it holds, and the life cycle of work, failure and
return. Its behaviour (scan, dig, haul) lives in a robot type as a simpy process.

A robot knows only what reached it on the bus and what it senses where it stands. It is
composed of parts, each a small class with the interface it needs of the robot declared
beside it:

- `mobility` (`Mobility`): where it is, the path it drives; every robot;
- `timed` (`TimedState`): what it is doing, timed; `wakes` (`Wake`): nudges to look again;
- `recovery` (`Recovery`): heartbeats, its peers' liveness, adoption, its return; every robot;
- `house` (`engine.auction_house.AuctionHouse`): its auctions and the winners it watches;
- `bidder` (`Bidder`): only a robot type that carries out auctioned tasks;
- `charging` (`Charging`): only a robot with a battery (the energy option on; never the
  operator's console).

Messages are routed to the parts by `engine.robots.hearing`; what a free robot does is
`engine.robots.standby`.
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, Any, Literal

import simpy

from engine.auction_house import AuctionHouse
from engine.auction_rules import AUCTION_KINDS
from engine.geometry import Point
from engine.messages import (
    Close,
    Hello,
    Leaving,
    Message,
    TaskDone,
    TaskType,
)
from engine.policies import coalition_partner
from engine.robots import standby
from engine.robots.charging import Charging
from engine.robots.core import Assignment
from engine.robots.hearing import HANDLERS, first_look, only_notes
from engine.robots.mobility import Mobility, Motion
from engine.robots.recovery import Recovery
from engine.robots.timed_state import TimedState
from engine.robots.wake import Wake
from engine.round_board import Rounds

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.robots.bidder import Bidder
    from engine.robots.search import Search


class Robot:
    """A robot of the team (or the operator's console): its parts, its state and tasks, and
    its life; the robot types fill in `life` or `work` and the hooks at the end."""

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
        self.battery = None if ctx.energy is None else ctx.energy.battery(self.rtype)
        self.mobility = Mobility(self, pos, speed)
        self.born_at = float(self.env.now)
        self.timed = TimedState("idle", self.born_at)
        self.alive = True
        self.enabled = True
        self.leaving = False
        self.partner = coalition_partner(name)  # Policy 2's pairing rule, fixed by the name
        self.current: Assignment | None = None
        self.queue: deque[Assignment] = deque()
        self._procs: list[Any] = []
        self.wakes = Wake(self.env)
        self.life_proc: Any = None
        self.peers = {name: self.rtype}  # name -> type, from the roster, Hello and heartbeats
        # latest round heard of every announced auction: where my knowledge of one lives
        # (`_on_announce`; on the ideal bus a re-announcement is noted by `first_look`, or
        # for every robot it need not visit, by the bus's board of rounds)
        self._board = ctx.bus.board
        self.rounds = Rounds(name, self._board)
        self.recovery = Recovery(self)
        self.house = _house_for(self)
        self.bidder: Bidder | None = None  # a robot type that bids sets its own
        self.search: Search | None = None  # a scout's
        self.charging: Charging | None = None if self.battery is None else Charging(self)
        ctx.liveness.add(name)
        ctx.bus.subscribe(name, self.on_message, self.rtype, self.hears, self.first_look)
        if self._board is not None:
            self._board.join(name, self.rtype, self.hears, self.rounds, self.only_notes)

    # --- what the parts hold, as the rest of the engine reads it ---------------------------
    @property
    def pos(self) -> Point:
        return self.mobility.pos

    @property
    def motion(self) -> Motion | None:
        return self.mobility.motion

    @property
    def speed(self) -> float:
        return self.mobility.speed

    @property
    def distance(self) -> float:
        return self.mobility.distance

    @property
    def down(self) -> set[str]:
        """The peers I think failed or gone."""
        return self.recovery.down

    # --- state ----------------------------------------------------------------------------
    @property
    def state(self) -> str:
        """What the robot is doing; every change is timed on the simulation clock."""
        return self.timed.value

    @state.setter
    def state(self, value: str) -> None:
        if self.timed.enter(value, float(self.env.now)):
            self.motion_changed()

    def motion_changed(self) -> None:
        """The draw on the battery may have changed (state or motion): settle and re-watch."""
        if self.battery is not None:
            energy = self.ctx.energy
            assert energy is not None
            energy.update(self)

    def state_times(self) -> dict[str, float]:
        """Seconds spent in each state since the robot joined, the current spell up to now."""
        return self.timed.times(float(self.env.now))

    @property
    def participating(self) -> bool:
        return self.alive and self.enabled and not self.leaving

    def wake(self) -> None:
        """Nudge the behaviour to look at its situation again (a wake is never lost)."""
        self.wakes.send()

    def wait_for_wake(self) -> simpy.Event:
        return self.wakes.wait()

    def spawn(self, gen: Any) -> None:
        """Run a side process of this robot; it ends quietly when the robot fails."""
        if len(self._procs) > 32:
            self._procs = [p for p in self._procs if p.is_alive]
        self._procs.append(self.env.process(_until_interrupted(gen)))

    def tasks_held(self) -> list[Assignment]:
        """The task I work on and those queued behind it."""
        return ([] if self.current is None else [self.current]) + list(self.queue)

    # --- what goes to the parts -------------------------------------------------------------
    def heartbeat(self) -> None:
        """Say I am alive and what I hold."""
        self.recovery.heartbeat()

    def check_peers(self) -> None:
        """Every heartbeat period: my peers' liveness, and the winners my house watches."""
        self.recovery.check_peers()

    def consider_bids(self) -> None:
        """Look at the open auctions again (a robot that bids)."""
        if self.bidder is not None:
            self.bidder.consider_bids()

    def policy_changed(self) -> None:
        """A new policy may bid in other units or by other rules: look at everything afresh."""
        if self.bidder is not None:
            self.bidder.look_afresh()

    # --- lifecycle ----------------------------------------------------------------------
    def start(self, joined_late: bool = False) -> None:
        self.life_proc = self.env.process(self._life_guarded())
        self._procs.append(self.life_proc)
        self.spawn(self.recovery.beat())
        if joined_late:
            self.ctx.bus.publish(
                Hello(
                    sender=self.name,
                    rtype=self.rtype,
                    wants_work=self.search is not None and self.search.wants_work(),
                )
            )

    def _life_guarded(self) -> Any:
        while True:
            try:
                yield from self.life()
                return
            except simpy.Interrupt as irq:
                if irq.cause != "revoked" or not self.alive:
                    return
                self.mobility.stop()  # the task was taken back: stop and look again
                self.on_revoked()

    def life(self) -> Any:
        """Work through the tasks won, one at a time; between them, what a free robot does."""
        while True:
            if self.leaving:
                self.go_quiet()
                return
            if self.charging is not None and self.charging.needs_charge():
                yield from self.charging.recharge()
                continue
            if self.queue:
                self.current = self.queue.popleft()
                self.tasks_changed()
                yield from self.work(self.current)
            else:
                yield from self.when_free()

    def work(self, a: Assignment) -> Any:
        """Carry out one won task; robots that win tasks override it."""
        raise NotImplementedError(f"{self.rtype} cannot carry out {a.task_type}")
        yield  # pragma: no cover - makes this a generator

    def when_free(self) -> Any:
        """Nothing to do: wait until something changes (where the policy says, if it does)."""
        yield from standby.when_free(self)

    def regain_contact(self) -> Any:
        """Radio range: drive back into the base station's reach (`standby.regain_contact`)."""
        yield from standby.regain_contact(self)

    def run_dry(self) -> None:
        """The battery is empty: the robot stops where it is, a failure like any other."""
        obs = self.ctx.observer
        obs.failures += 1
        self.fail()
        obs.emit("robot_failed", robot=self.name, x=self.pos[0], y=self.pos[1], cause="energy")

    def on_message(self, msg: Message) -> None:
        """Every message the bus brings me, handed to the part it concerns."""
        if not self.alive:
            return
        handler = HANDLERS.get(type(msg))
        if handler is not None:
            handler(self, msg)

    first_look = first_look
    """The ideal bus's shortcut for a re-announcement (`engine.robots.hearing.first_look`)."""
    only_notes = only_notes
    """The same look without its effect (asked by the board of rounds when checking)."""

    def tasks_changed(self) -> None:
        """What I hold (current and queued) changed: the board of rounds keeps who holds
        which task, and whether I may have room to bid again."""
        if self._board is not None:
            cur, held = self.current, {a.task_id for a in self.queue}
            if cur is not None:
                held.add(cur.task_id)
            self._board.held(self.name, frozenset(held))

    def stir(self) -> None:
        """Something my bidding reads changed outside the bidder (my battery)."""
        if self._board is not None:
            self._board.stir(self.name)

    # --- tasks --------------------------------------------------------------------------
    def assign(self, a: Assignment) -> None:
        self.queue.append(a)
        self.tasks_changed()
        self.ctx.observer.emit(
            "task_started",
            robot=self.name,
            task_id=a.task_id,
            task_type=a.task_type,
            auction_id=a.auction_id,
        )
        self.wake()

    def finish(self, a: Assignment, outcome: Literal["done", "void", "released"] = "done") -> None:
        self.current = None
        self.tasks_changed()
        if outcome != "released":  # a released task is not done: its watcher offers it again
            self.recovery.done_ids.append(a.task_id)
        if outcome == "done" or (outcome == "void" and a.task_type == "transport"):
            self.recovery.completed.add(a.task_id)  # final: no one need ever carry this again
            if self._board is not None:
                self._board.finished(self.name, a.task_id)
        self.ctx.observer.emit("task_ended", robot=self.name, task_id=a.task_id, outcome=outcome)
        self.ctx.bus.publish(
            TaskDone(sender=self.name, auction_id=a.auction_id, task_id=a.task_id, outcome=outcome)
        )
        self.consider_bids()

    # --- operator-driven failures -------------------------------------------------------
    def fail(self) -> None:
        """Abrupt failure: stop where it is; nothing is sent or answered any more."""
        self.mobility.stop()
        self.alive = False
        self.enabled = False
        self.state = "failed"
        me = self.env.active_process  # a graceful exit runs inside the robot's own process
        for p in self._procs:
            if p.is_alive and p is not me:
                p.interrupt("failed")
        self._procs.clear()
        duties = self.house.stop()
        self.ctx.bus.note_unclosed(rec.id for rec in duties.auctions)
        self.recovery.dormant = self.recovery.dormant.merge(duties)
        self.drop_loads()
        self.current = None
        self.queue.clear()
        self.tasks_changed()

    def disable(self) -> None:
        """Graceful: take nothing new, finish the current hand-over, then say goodbye."""
        self.leaving = True
        self.wake()

    def go_quiet(self) -> None:
        """The end of a graceful disable: announce it, then stop like a failure. Its open
        auctions stay open for the peer that adopts them (cancelling would lose their tasks)."""
        progress = 0 if self.search is None else self.search.progress()
        self.ctx.bus.publish(Leaving(sender=self.name, progress=progress))
        self.fail()
        self.state = "disabled"
        self.ctx.observer.emit("robot_quiet", robot=self.name)

    def enable(self) -> None:
        """Back from a failure (a new life): a full peer at once for bidding and working; its
        earlier duties are settled after a listening period (`Recovery.rejoin`)."""
        self.alive = True
        self.enabled = True
        self.leaving = False
        if self.battery is not None:  # the operator's rescue brings it back charged
            self.battery.settle(float(self.env.now))
            self.battery.level = self.battery.capacity
            self.battery.must_charge = False
        self.state = "idle"
        self.current = None
        self.queue.clear()
        self.tasks_changed()
        self.rounds.clear()
        if self.bidder is not None:
            self.bidder.reset()
        recovery = self.recovery
        recovery.forget_verdicts()
        self.house = _house_for(self)
        recovery.rejoining = True
        recovery.taken_back = set()
        self.start(joined_late=True)
        self.spawn(recovery.rejoin())

    # --- hooks the robot types fill in ----------------------------------------------------
    def load(self) -> int:
        """Minerals aboard (a bucket, a bin)."""
        return 0

    def drop_loads(self) -> None:
        """Failed: whatever it carries falls where it stands."""

    def on_revoked(self) -> None:
        """The current task was revoked mid-way: tidy up and look again."""
        self.current = None
        self.tasks_changed()
        self.consider_bids()

    def on_close_heard(self, msg: Close) -> None:
        """Any Close (a hauler learns where its coalition partner works)."""

    def on_task_done_heard(self, msg: TaskDone) -> None:
        """Any TaskDone."""

    def on_rejoined(self) -> None:
        """My earlier duties are settled."""


def _house_for(robot: Robot) -> AuctionHouse:
    """A robot's auctioneer part, for a new life: it offers a lost task again unless a live
    peer of its type already does."""
    return AuctionHouse(
        robot.name,
        robot.ctx,
        kind=AUCTION_KINDS.get(robot.rtype, "operator"),
        peer_offers=robot.recovery.peer_duties.peer_handles,
        holders_carry=robot.rtype != "scout",  # a site does not move with its excavator
    )


def _until_interrupted(gen: Any) -> Any:
    try:
        yield from gen
    except simpy.Interrupt:
        return
