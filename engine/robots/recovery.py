"""The recovery role every robot plays: heartbeats, noticing a silent peer (probes before a
verdict), re-auctioning what it held, adopting a dead peer's auctions and watched tasks, and
settling false alarms (Holding/Revoke). Split from `base` so each file holds one concept."""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, Any

from engine.auction_rules import AUCTION_KINDS, Duties
from engine.messages import Heartbeat, Holding, Leaving, Probe, Revoke, Takeover
from engine.robots.core import RobotCore

if TYPE_CHECKING:
    pass


class Recovery(RobotCore):
    """The recovery role of a robot."""

    # --- liveness, monitoring, adoption ---------------------------------------------------
    def heartbeat(self) -> None:
        pos, _ = self.position()
        tasks = tuple(a.task_id for a in self.tasks_held())
        load = self.load()
        self.ctx.bus.publish(
            # built from this robot's own state, whose types are the message's: validation
            # is for what arrives from outside (`field.wire.decode`), and a heartbeat is the
            # commonest message there is
            Heartbeat.model_construct(
                sender=self.name,
                rtype=self.rtype,
                t=float(self.env.now),
                x=pos[0],
                y=pos[1],
                state=self.state,
                tasks=tasks,
                open_auctions=self.house.open_ids(),
                progress=self.progress(),
                # the route matters only to whoever must search for a mineral I carry
                path=tuple(self.remaining_route()[:16]) if load else (),
                load=load,
                done=tuple(self.done_ids),
                adopted=tuple(self.adopted),
                received=self.handoffs_received(),
            )
        )

    def check_peers(self) -> None:
        proto = self.ctx.scenario.protocol
        now = float(self.env.now)
        board = self.ctx.liveness
        back = [p for p in self.down if board.last_heard(self.name, p) > self.down_at[p]]
        for peer in back:
            self.down.discard(peer)  # heard again since: it is back
            self._in_order = None
        if back:  # its auctions count again, and a partner may be back: look again
            self.wake()
            self.consider_bids()
        radio = self.ctx.radio
        for peer in board.silent(self.name, now, proto.failure_timeout_s):
            if peer not in self.down and peer not in self._probing:
                if radio is not None and radio.presumed_out_of_reach(self, peer, now):
                    continue  # out of range is not failed: it gets radio.silent_timeout_s
                self._probing.add(peer)
                self._spawn(self._probe(peer))
        # an auction whose auctioneer no longer lists it has closed (we missed the Close)
        latest: dict[str, Heartbeat | None] = {}
        for aid, info in list(self.open_auctions.items()):
            who = info.auctioneer
            hb = (
                latest[who]
                if who in latest
                else latest.setdefault(who, board.last_heartbeat(self.name, who))
            )
            if hb is not None and hb.t > info.opened_at + 1e-9 and aid not in hb.open_auctions:
                self.forget_auction(aid)
        # a winner that neither lists a task nor reports it done has dropped it
        self.house.check_winners(2 * proto.heartbeat_s + proto.ack_timeout_s)

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
        if peer not in self.down and self.participating:
            self.mark_down(peer)

    def peer_down(self, peer: str) -> None:
        """`peer` fell silent or left: re-auction what it held from me, adopt its duties."""
        self.ctx.observer.emit("failure_detected", by=self.name, robot=peer)
        self.house.winner_down(peer)
        for aid, info in list(self.open_auctions.items()):
            if info.auctioneer == peer:
                self.forget_auction(aid)
        if self.reserved is not None and self.reserved.auctioneer == peer:
            self.reserved = None
        if self.peer_type(peer) == self.rtype and self.is_adopter(peer):
            self.adopt(peer)
        self.consider_bids()

    def is_adopter(self, peer: str) -> bool:
        """The smallest-named live robot of my type adopts a silent peer."""
        if not self.participating:
            return False
        for name in self.peers_of_type(self.rtype):
            if name == peer or name in self.down:
                continue
            if name == self.name:
                return True
            if self.peer_alive(name):
                return False
        return False

    def adopt(self, peer: str) -> None:
        opened: list[str] = []
        tasks: list[str] = []
        kind = AUCTION_KINDS.get(self.rtype, "operator")
        for info in self.peer_open.pop(peer, {}).values():
            rec = self.house.open(
                info.task_type,
                info.location,
                info.task_id,
                kind=kind,
                search_path=info.search_path,
                reauction_of=info.auction_id,
            )
            opened.append(rec.id)
            tasks.append(info.task_id)
        for tid, alloc in self.forget_peer_allocs(peer).items():
            tasks.append(tid)
            if alloc.winner in self.down:  # search where its holder was last heard carrying it
                self.house.reoffer(alloc, self.ctx.liveness.last_heartbeat(self.name, alloc.winner))
            else:
                self.house.watch(alloc)
        self.adopted[peer] = opened
        self.adopted_tasks[peer] = tuple(tasks)
        self.adopted_cells[peer] = tuple(self.adopt_extra(peer))
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

    def adopt_extra(self, peer: str) -> list[int]:
        """Hook: scouts take over the peer's unscanned cells."""
        return []

    # --- coming back from a failure -------------------------------------------------------
    def rejoin(self) -> Any:
        """Settle the duties I held before I failed. Every peer that took some over says so
        again when it hears my Hello (`return_duties`); after listening for 1.5 heartbeat
        periods I take up the rest. No task is left with nobody; one whose Takeover was lost
        is held twice for a while, which the protocol resolves (an auctioneer runs one auction
        per task, duplicates between auctioneers go to the smaller name, Holding/Revoke)."""
        yield self.env.timeout(1.5 * self.ctx.scenario.protocol.heartbeat_s)
        mine = self.dormant.without(self.taken_back)
        kept = mine.without({t for t in mine.task_ids() if self.peer_handles(t)})
        self.dormant = Duties()
        self.rejoining = False
        self.house.resume(kept)
        self.ctx.observer.emit(
            "duties_settled",
            robot=self.name,
            resumed=len(kept.auctions) + len(kept.watches),
            handed_over=len(self.taken_back),
        )
        self.on_rejoined()

    def return_duties(self, peer: str) -> None:
        """A peer whose duties I adopted is back: tell it what I hold of them, and keep it."""
        if peer in self.adopted and self.participating:
            self._publish_takeover(peer)
            self._forget_adoption(peer)

    def on_cells_taken(self, cells: tuple[int, ...]) -> None:
        """Hook: scouts drop the cells a peer scans for them now."""

    def on_rejoined(self) -> None:
        """Hook: my earlier duties are settled."""

    def peer_handles(self, task_id: str) -> bool:
        """Does a live peer of my type run an auction for this task? Only what is fresh counts:
        announced since its last heartbeat, or listed in it (my memory of peers may be old)."""
        board = self.ctx.liveness
        for peer, auctions in self.peer_open.items():
            if not self.peer_alive(peer):
                continue
            hb = board.last_heartbeat(self.name, peer)
            for aid, a in auctions.items():
                fresh = hb is None or hb.t <= a.opened_at or aid in hb.open_auctions
                if a.task_id == task_id and fresh:
                    return True
        return False

    def _on_holding(self, msg: Holding) -> None:
        """A robot I re-auctioned a task from is alive and still on it: it keeps the task."""
        self.house.holder_says(msg.task_id, msg.sender)

    def _on_revoke(self, msg: Revoke) -> None:
        if msg.robot != self.name:
            return
        self.queue = deque(a for a in self.queue if a.task_id != msg.task_id)
        cur = self.current
        if cur is not None and cur.task_id == msg.task_id:
            if self.load():  # carrying the mineral: this robot is the real holder
                self.ctx.bus.publish(
                    Holding(sender=self.name, task_id=cur.task_id, auction_id=cur.auction_id)
                )
            elif self._life_proc is not None and self._life_proc.is_alive:
                self.ctx.observer.emit(
                    "task_ended", robot=self.name, task_id=cur.task_id, outcome="revoked"
                )
                self._life_proc.interrupt("revoked")

    def _on_probe(self, msg: Probe) -> None:
        if msg.target == self.name and self.participating:
            self.heartbeat()

    def _forget_adoption(self, peer: str) -> None:
        self.adopted.pop(peer, None)
        self.adopted_tasks.pop(peer, None)
        self.adopted_cells.pop(peer, None)

    def _on_takeover(self, msg: Takeover) -> None:
        if msg.failed == self.name:
            if self.rejoining:  # a peer holds these of my earlier duties now
                self.taken_back.update(msg.tasks)
                self.on_cells_taken(msg.cells)
            return
        mine = self.adopted.get(msg.failed)
        if mine is not None and msg.sender < self.name:
            self.house.drop_adopted(mine)
            self._forget_adoption(msg.failed)
            self.on_adoption_undone(msg.failed)
        self.peer_open.pop(msg.failed, None)
        self.forget_peer_allocs(msg.failed)
        self.on_takeover_heard(msg)

    def on_adoption_undone(self, failed: str) -> None:
        """Hook: a peer with a smaller name adopted `failed` too; it keeps the work."""

    def on_takeover_heard(self, msg: Takeover) -> None:
        """Hook for subclasses."""

    def _on_leaving(self, msg: Leaving) -> None:
        if msg.sender not in self.down:
            self.mark_down(msg.sender)

    def mark_down(self, peer: str) -> None:
        self.down.add(peer)
        self._in_order = None
        self.down_at[peer] = float(self.env.now)
        self.peer_down(peer)
