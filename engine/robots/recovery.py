"""The recovery part every robot has: heartbeats, what it knows of its peers (who they are,
whom it thinks down, what they auction and watch: the last kept in `engine.robots.peer_duties`),
noticing a silent peer (probes before a verdict), adopting a dead peer's auctions and watched
tasks, settling false alarms (Holding/Revoke), and settling its own duties when it comes back
from a failure.

Watching the winners of its own auctions and offering their tasks again is the auction
house's (`engine.auction_house`); this part tells the house when a winner is found down.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import simpy

from engine.auction_rules import AUCTION_KINDS, Allocation, Duties
from engine.messages import Heartbeat, Hello, Holding, Leaving, Probe, Revoke, Takeover, TaskDone
from engine.policies import coalition_partner
from engine.robots.peer_duties import PeerDuties
from engine.robots.recovery_ports import RecoveringRobot

DONE_MEMORY = 8
"""How many finished task ids a heartbeat repeats, for auctioneers that missed a TaskDone."""


class Recovery:
    """Liveness, adoption and the return from a failure, for one robot."""

    def __init__(self, robot: RecoveringRobot) -> None:
        self.robot = robot
        self.name = robot.name
        self.ctx = robot.ctx
        self.env = robot.ctx.env
        self._probing: set[str] = set()
        # Memory that survives a failure: what others were responsible for (for adoption,
        # `PeerDuties`), whose duties I took over, tasks I finished, and my own duties while I
        # am down.
        self.peer_duties = PeerDuties(self)
        self.adopted: dict[str, list[str]] = {}  # failed peer -> auction ids I opened for it
        self.adopted_tasks: dict[str, tuple[str, ...]] = {}  # failed peer -> its tasks I hold
        self.adopted_cells: dict[str, tuple[int, ...]] = {}  # failed peer -> its cells I scan
        self.done_ids: deque[str] = deque(maxlen=DONE_MEMORY)
        self.completed: set[str] = set()  # tasks I finished for good
        self.dormant = Duties()
        self.rejoining = False
        self.taken_back: set[str] = set()  # my tasks a peer took over while I was down
        self.forget_verdicts()

    def forget_verdicts(self) -> None:
        """A new life: nobody is thought down."""
        self.down: set[str] = set()
        self.down_at: dict[str, float] = {}
        self.taken_over: set[str] = set()  # peers down whose Takeover by another I heard

    # --- heartbeats and peers -------------------------------------------------------------
    def beat(self) -> Any:
        """Every heartbeat period (offset by my place on the board): say I am alive, and
        look at my peers (`check_peers`)."""
        robot = self.robot
        proto = self.ctx.scenario.protocol
        offset = (self.ctx.liveness.index[self.name] % 10) * proto.heartbeat_s / 10
        try:
            yield self.env.timeout(offset)
            while True:
                robot.heartbeat()
                robot.check_peers()
                yield self.env.timeout(proto.heartbeat_s)
        except simpy.Interrupt:
            return

    def heartbeat(self) -> None:
        robot = self.robot
        pos, _ = robot.mobility.position()
        tasks = tuple(a.task_id for a in robot.tasks_held())
        load = robot.load()
        self.ctx.bus.publish(
            Heartbeat(
                sender=self.name,
                rtype=robot.rtype,
                t=float(self.env.now),
                x=pos[0],
                y=pos[1],
                state=robot.state,
                tasks=tasks,
                open_auctions=robot.house.open_ids(),
                progress=0 if robot.search is None else robot.search.reported(),
                # the route matters only to whoever must search for a mineral I carry
                path=tuple(robot.mobility.remaining_route()[:16]) if load else (),
                load=load,
                done=tuple(self.done_ids),
                adopted=tuple(self.adopted),
                received=() if robot.search is None else robot.search.handoffs_received(),
            )
        )

    def peer_type(self, name: str) -> str | None:
        """What a peer is, as far as messages have told me (None: never heard of it)."""
        peers = self.robot.peers
        rtype = peers.get(name)
        if rtype is None:
            hb = self.ctx.liveness.last_heartbeat(self.name, name)
            if hb is not None:
                rtype = peers[name] = hb.rtype
        return rtype

    def peers_of_type(self, rtype: str) -> list[str]:
        """Every robot of this type I know of, me included, by name."""
        for name in self.ctx.liveness.names:  # the senders whose heartbeats reach me
            self.peer_type(name)
        return sorted(n for n, t in self.robot.peers.items() if t == rtype)

    def peer_alive(self, name: str) -> bool:
        heard = self.ctx.liveness.last_heard(self.name, name)
        timeout = self.ctx.scenario.protocol.failure_timeout_s
        return name not in self.down and self.env.now - heard <= timeout

    def alive_until(self, name: str) -> float:
        """When `peer_alive` may turn false unless the peer is heard again or found down (both
        of which stir my bidder): -inf if it is not alive now."""
        heard = self.ctx.liveness.last_heard(self.name, name)
        timeout = self.ctx.scenario.protocol.failure_timeout_s
        if name in self.down or self.env.now - heard > timeout:  # `peer_alive`, inverted
            return -math.inf
        return heard + timeout

    # --- noticing a silent peer -----------------------------------------------------------
    def check_peers(self) -> None:
        robot = self.robot
        proto = self.ctx.scenario.protocol
        now = float(self.env.now)
        board = self.ctx.liveness
        bidder = robot.bidder
        back = [p for p in self.down if board.last_heard(self.name, p) > self.down_at[p]]
        for peer in back:
            self.down.discard(peer)  # heard again since: it is back
            self.taken_over.discard(peer)
            if bidder is not None:
                bidder.auctioneers_changed()
        if back:  # its auctions count again, and a partner may be back: look again
            robot.wake()
            robot.consider_bids()
        radio = self.ctx.radio
        for peer in board.silent(self.name, now, proto.failure_timeout_s):
            if peer not in self.down and peer not in self._probing:
                if radio is not None and radio.presumed_out_of_reach(robot, peer, now):
                    continue  # out of range is not failed: it gets radio.silent_timeout_s
                self._probing.add(peer)
                robot.spawn(self._probe(peer))
        if bidder is not None:
            bidder.missed_closes()
        # a winner that neither lists a task nor reports it done has dropped it
        robot.house.watches.check(2 * proto.heartbeat_s + proto.ack_timeout_s)
        if robot.search is not None:
            robot.search.check_handoffs()

    def _probe(self, peer: str) -> Any:
        """Ask a silent peer directly a few times before declaring it failed: on a lossy bus a
        run of lost heartbeats is not a failure, and a false alarm costs a duplicate task."""
        proto = self.ctx.scenario.protocol
        asked_at = float(self.env.now)
        try:
            for _ in range(proto.probes):
                self.ctx.bus.publish(Probe(sender=self.name, target=peer))
                yield self.env.timeout(proto.ack_timeout_s)
                if self.ctx.liveness.last_heard(self.name, peer) >= asked_at:
                    return
        finally:
            self._probing.discard(peer)
        # a robot leaving still finishes its hand-over, so it must see the hauler it waits
        # on fall (attrition seed 77: it waited for ever, and kept its peers from adopting)
        if peer not in self.down and self.robot.alive:
            self.mark_down(peer)

    def mark_down(self, peer: str) -> None:
        self.down.add(peer)
        if self.robot.bidder is not None:
            self.robot.bidder.auctioneers_changed()
        self.down_at[peer] = float(self.env.now)
        self.peer_down(peer)

    def peer_down(self, peer: str) -> None:
        """`peer` fell silent or left: the house offers again what it held, its auctions are
        forgotten, and the smallest-named live robot of its type adopts its duties."""
        robot = self.robot
        self.ctx.observer.emit("failure_detected", by=self.name, robot=peer)
        robot.house.watches.winner_down(peer)
        self._adopted_partners_load(peer)
        if robot.bidder is not None:
            robot.bidder.auctioneer_down(peer)
        if self.peer_type(peer) == robot.rtype:
            if self.is_adopter(peer):
                self.adopt(peer)
            self._adopt_orphans(peer)
        robot.consider_bids()

    def _adopted_partners_load(self, hauler: str) -> None:
        """`hauler` fell: if it was the Policy-2 partner of an excavator I adopted, what it
        carried for that excavator may have been loaded after my adoption (a graceful leave
        ends just after its hand-over), so nobody watches it: offered again along its route
        (attrition seed 172: the load lay on the road for ever)."""
        if self.robot.rtype != "excavator":
            return  # (the partner rule is symmetric: a hauler's adopted peers have partners too)
        house = self.robot.house
        kin = [q for p in self.adopted for q in self.peer_duties.with_its_adoptions(p)]
        for peer in [q for q in kin if coalition_partner(q) == hauler]:
            for tid, alloc in self.peer_duties.hand_over_unheard(peer).items():
                if not house.handles(tid):
                    house.reoffer(alloc, self.ctx.liveness.last_heartbeat(self.name, hauler))

    def _adopt_orphans(self, fallen: str) -> None:
        """`fallen` may have been the adopter of a peer that failed before it and fell before
        it noticed: that peer's duties are nobody's. A peer of my type down by my verdict,
        whose adoption nobody announced (no Takeover heard, no heartbeat of my type lists it)
        is mine now if I am its adopter (field chaos seed 1: two sites never dug)."""
        rtype = self.robot.rtype
        board = self.ctx.liveness
        kin = self.peers_of_type(rtype)
        for p in sorted(self.down - {fallen} - set(self.adopted) - self.taken_over):
            if self.peer_type(p) != rtype:
                continue
            beats = (board.last_heartbeat(self.name, n) for n in kin if n != p)
            if any(hb is not None and p in hb.adopted for hb in beats):
                continue
            if self.is_adopter(p):
                self.adopt(p)

    def is_adopter(self, peer: str) -> bool:
        """The smallest-named live robot of my type adopts a silent peer."""
        if not self.robot.participating:
            return False
        for name in self.peers_of_type(self.robot.rtype):
            if name == peer or name in self.down:
                continue
            if name == self.name:
                return True
            if self.peer_alive(name):
                return False
        return False

    def adopt(self, peer: str) -> None:
        house = self.robot.house
        opened: list[str] = []
        tasks: list[str] = []
        kind = AUCTION_KINDS.get(self.robot.rtype, "operator")
        # an auction whose Close I missed is not open: its task is watched, or offered again
        # from where its holder was last heard (not from the auction's own place)
        closed = self.peer_duties.closed_unheard(peer)
        handed: dict[str, Allocation] = {}
        if kind == "excavator_hauler":
            for q in self.peer_duties.with_its_adoptions(peer):
                handed.update(self.peer_duties.hand_over_unheard(q))
        for info in self.peer_duties.peer_open.pop(peer, {}).values():
            rec = house.open(
                info.task_type,
                info.location,
                info.task_id,
                kind=kind,
                search_path=info.search_path,
                reauction_of=info.auction_id,
            )
            opened.append(rec.id)
            tasks.append(info.task_id)
        for tid in [t for t in handed if house.handles(t)]:
            del handed[tid]  # a task of mine its partner won in my auction
        allocs = {**handed, **self.peer_duties.forget_peer_allocs(peer), **closed}
        for tid, alloc in allocs.items():
            tasks.append(tid)
            if alloc.winner in self.down:  # search where its holder was last heard carrying it
                house.reoffer(alloc, self.ctx.liveness.last_heartbeat(self.name, alloc.winner))
            else:
                house.watches.add(alloc)
        self.adopted[peer] = opened
        self.adopted_tasks[peer] = tuple(tasks)
        search = self.robot.search
        self.adopted_cells[peer] = tuple(() if search is None else search.adopt_extra(peer))
        self.ctx.observer.emit("takeover", by=self.name, robot=peer, auctions=opened)
        self._publish_takeover(peer)

    def _publish_takeover(self, peer: str) -> None:
        self.ctx.bus.publish(
            Takeover(
                sender=self.name,
                failed=peer,
                cells=self.adopted_cells.get(peer, ()),
                tasks=self.adopted_tasks.get(peer, ()),
            )
        )

    def _forget_adoption(self, peer: str) -> None:
        self.adopted.pop(peer, None)
        self.adopted_tasks.pop(peer, None)
        self.adopted_cells.pop(peer, None)

    # --- coming back from a failure -------------------------------------------------------
    def rejoin(self) -> Any:
        """Settle the duties I held before I failed. Every peer that took some over says so
        again when it hears my Hello (`return_duties`); after listening for 1.5 heartbeat
        periods I take up the rest. No task is left with nobody; one whose Takeover was lost
        is held twice for a while, which the protocol resolves (an auctioneer runs one auction
        per task, duplicates between auctioneers go to the smaller name, Holding/Revoke)."""
        yield self.env.timeout(1.5 * self.ctx.scenario.protocol.heartbeat_s)
        dormant = self.dormant
        mine = dormant.without(self.taken_back)
        kept = mine.without({t for t in mine.task_ids() if self.peer_duties.peer_handles(t)})
        self.dormant = Duties()
        self.rejoining = False
        self.robot.house.resume(kept)
        # the auctions a peer runs now in my place are over for me: their records say so
        resumed = {r.id for r in kept.auctions}
        self.robot.house.give_up([r for r in dormant.auctions if r.id not in resumed])
        self.ctx.observer.emit(
            "duties_settled",
            robot=self.name,
            resumed=len(kept.auctions) + len(kept.watches),
            handed_over=len(self.taken_back),
        )
        self.robot.on_rejoined()

    # --- messages -------------------------------------------------------------------------
    def on_hello(self, msg: Hello) -> None:
        """A newcomer (or a robot back): it hears my open auctions, and what I hold of its
        earlier duties is said again, and kept."""
        self.robot.peers[msg.sender] = msg.rtype
        self.robot.house.reannounce_open()
        if msg.sender in self.adopted and self.robot.participating:
            self._publish_takeover(msg.sender)
            self._forget_adoption(msg.sender)
        if self.robot.search is not None:  # scouts share their remaining cells with it
            self.robot.search.on_hello_heard(msg)

    def on_task_done(self, msg: TaskDone) -> None:
        # only the robot a task was allocated to ends that allocation (a duplicate holder's
        # "void" must not end the real holder's watch); a released task is its watcher's to
        # offer again, and stays in my record of it until it does (it may fall first)
        if msg.outcome != "released":
            self.peer_duties.end_peer_alloc(msg.task_id, msg.sender)
        if self.robot.rtype == "excavator" and self.ctx.policy.coalitions():
            self.peer_duties.last_done[msg.sender] = msg.task_id  # for `hand_over_unheard`
        self.robot.house.task_done(msg)
        self.robot.on_task_done_heard(msg)

    def on_holding(self, msg: Holding) -> None:
        """A robot I re-auctioned a task from is alive and still on it: it keeps the task."""
        self.robot.house.holder_says(msg.task_id, msg.sender)

    def on_revoke(self, msg: Revoke) -> None:
        robot = self.robot
        if msg.robot != self.name:
            return
        if robot.bidder is not None:
            robot.bidder.revoked(msg.task_id)
        robot.queue = deque(a for a in robot.queue if a.task_id != msg.task_id)
        robot.tasks_changed()
        cur = robot.current
        if cur is not None and cur.task_id == msg.task_id:
            if robot.load():  # carrying the mineral: this robot is the real holder
                self.ctx.bus.publish(
                    Holding(sender=self.name, task_id=cur.task_id, auction_id=cur.auction_id)
                )
            elif robot.life_proc is not None and robot.life_proc.is_alive:
                self.ctx.observer.emit(
                    "task_ended", robot=self.name, task_id=cur.task_id, outcome="revoked"
                )
                robot.life_proc.interrupt("revoked")

    def on_probe(self, msg: Probe) -> None:
        if msg.target == self.name and self.robot.participating:
            self.robot.heartbeat()

    def on_takeover(self, msg: Takeover) -> None:
        if msg.failed == self.name:
            if self.rejoining:  # a peer holds these of my earlier duties now
                self.taken_back.update(msg.tasks)
                if self.robot.search is not None:
                    self.robot.search.on_cells_taken(msg.cells)
            return
        self.taken_over.add(msg.failed)
        mine = self.adopted.get(msg.failed)
        if mine is not None and msg.sender < self.name:
            self.robot.house.drop_adopted(mine)
            self._forget_adoption(msg.failed)
            if self.robot.search is not None:
                self.robot.search.on_adoption_undone(msg.failed)
        self.peer_duties.peer_open.pop(msg.failed, None)
        for tid, alloc in self.peer_duties.forget_peer_allocs(msg.failed).items():
            if tid in msg.tasks:  # its adopter watches it now: adopted with it if it falls too
                self.peer_duties.note_peer_alloc(msg.sender, alloc)
        if self.robot.search is not None:
            self.robot.search.on_takeover_heard(msg)

    def on_leaving(self, msg: Leaving) -> None:
        if msg.sender not in self.down:
            self.mark_down(msg.sender)
