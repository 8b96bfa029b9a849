"""What an auctioneer keeps after a close (docs/spec.md §6, step 6; §10): each task it
allocated, watched until its winner reports it done, so a task whose winner fails, drops it or
releases it is offered again. `engine.auction_house.AuctionHouse` owns one and decides how a
task is offered again (`reoffer`); this decides when."""

from __future__ import annotations

from collections.abc import Callable, Iterator

from engine.auction_ports import AuctionPorts
from engine.auction_rules import Allocation
from engine.messages import Heartbeat, Revoke, TaskDone

Reoffer = Callable[[Allocation, Heartbeat | None], None]


class Watches:
    """The allocations of one auctioneer whose winners have not yet reported them done, by
    task. `reoffer(alloc, hb)` offers a lost task again (`hb`: its holder's last word)."""

    def __init__(self, owner: str, ports: AuctionPorts, reoffer: Reoffer) -> None:
        self.owner = owner
        self.ports = ports
        self._reoffer = reoffer
        self._by_task: dict[str, Allocation] = {}

    def __contains__(self, task_id: object) -> bool:
        """Was this task allocated here, its winner not yet done with it?"""
        return task_id in self._by_task

    def __iter__(self) -> Iterator[Allocation]:
        """The allocations watched now (a copy: reading may end a watch)."""
        return iter(list(self._by_task.values()))

    def winner_of(self, task_id: str) -> str | None:
        """The robot watched for this task, if it was allocated here."""
        alloc = self._by_task.get(task_id)
        return None if alloc is None else alloc.winner

    def add(self, alloc: Allocation) -> None:
        """Watch an allocation: an auction's close, a hand-over, an adopted watch."""
        self._by_task[alloc.task_id] = alloc

    def take(self) -> dict[str, Allocation]:
        """Every watch, handed over and forgotten here (the owner failed)."""
        taken = dict(self._by_task)
        self._by_task.clear()
        return taken

    def drop_auctions(self, auction_ids: list[str]) -> None:
        """Let go the watches of these auctions (adopted by a peer that keeps them)."""
        for tid, alloc in list(self._by_task.items()):
            if alloc.auction_id in auction_ids:
                del self._by_task[tid]

    def check(self, grace: float) -> None:
        """A winner that neither lists a task in its heartbeat nor reports it done has dropped
        it: offered again. One that reports it done ends the watch (its TaskDone was lost).
        One that lists it holds it, whatever its list of finished tasks says: a site's task
        can come back to a robot that once found it worked by another ("void")."""
        board = self.ports.liveness
        for tid, alloc in list(self._by_task.items()):
            hb = board.last_heartbeat(self.owner, alloc.winner)
            if hb is None or hb.t < alloc.since + grace or tid in hb.tasks:
                continue
            del self._by_task[tid]
            if tid not in hb.done:
                self._reoffer(alloc, hb)

    def winner_down(self, peer: str) -> None:
        """`peer` failed or left: every task it won here is offered again."""
        board = self.ports.liveness
        for tid, alloc in list(self._by_task.items()):
            if alloc.winner == peer:
                del self._by_task[tid]
                self._reoffer(alloc, board.last_heartbeat(self.owner, peer))

    def task_done(self, msg: TaskDone) -> None:
        """A TaskDone: only the robot a task was allocated to ends its watch (a duplicate
        holder's "void" must not end the real holder's); a released task is offered again.

        A "void" from my winner while another robot's heartbeat lists the task means that
        robot works it (a site found worked: its holder had been thought down, out of radio
        reach say, and the task given again): I watch that robot instead, so its letting go
        later is seen in its heartbeats even if its TaskDone does not reach me."""
        alloc = self._by_task.get(msg.task_id)
        if alloc is None or alloc.winner != msg.sender:
            return
        del self._by_task[msg.task_id]
        if msg.outcome == "released":
            self._reoffer(alloc, None)
        elif msg.outcome == "void":
            holder = self.ports.liveness.holder_of(self.owner, msg.task_id, but=msg.sender)
            if holder is not None:
                alloc.winner, alloc.since = holder, float(self.ports.env.now)
                self._by_task[msg.task_id] = alloc

    def keep_holder(self, task_id: str, holder: str) -> None:
        """`holder` is alive and still on a task watched here for another robot: the other is
        revoked, and the holder watched instead."""
        alloc = self._by_task.get(task_id)
        if alloc is not None and alloc.winner != holder:
            self.ports.publish(Revoke(sender=self.owner, task_id=task_id, robot=alloc.winner))
            self.ports.emit("task_revoked", by=self.owner, robot=alloc.winner, task_id=task_id)
            alloc.winner = holder
