"""What a robot has heard of the duties of its peers of its type (`PeerDuties`): the auctions
each runs and the tasks each allocated and watches, and whether a live peer already offers a
task.

It exists apart from recovery (`engine.robots.recovery`), which acts on it (adopting a silent
peer's duties, settling its own after a failure), because it is a record with an index of its
own (a task's allocations are found through the task, not by a look at every peer), kept as
the bus tells of auctions, closes and finished tasks, and across the robot's failures.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from engine.auction_rules import Allocation
from engine.bidding import OpenAuction
from engine.policies import coalition_partner

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.messages import Heartbeat


class PeerLiveness(Protocol):
    """What the record reads of its robot's recovery part (`Recovery`): who it is, the
    heartbeats it heard, and whether it thinks a peer alive."""

    name: str
    ctx: MissionContext

    def peer_alive(self, name: str) -> bool: ...


class PeerDuties:
    """The duties of a robot's peers of its type, as far as it heard: their open auctions
    (`peer_open`, from their announcements) and the tasks they allocated (`peer_alloc`, from
    their Closes, until the winner reports the task finished)."""

    def __init__(self, recovery: PeerLiveness) -> None:
        self.recovery = recovery
        self.peer_open: dict[str, dict[str, OpenAuction]] = {}
        self.peer_alloc: dict[str, dict[str, Allocation]] = {}
        self._alloc_peers: dict[str, set[str]] = {}  # task id -> peers whose peer_alloc has it
        # robot -> the task of its last TaskDone I heard (kept by excavators under Policy 2)
        self.last_done: dict[str, str] = {}

    def note_peer_open(self, peer: str, info: OpenAuction) -> None:
        """A peer of my type announced an auction. An auctioneer runs one auction per task, so
        an earlier one of the same task is over, whether or not I heard its Close (a lossy
        bus): adopting the peer must offer the task as it offered it last, not as it once did
        (a lost mineral searched for at its pick-up point instead of along its route). So is
        its earlier allocation: one released stays in my record until this moment, in case
        the peer falls before it offers the task again."""
        auctions = self.peer_open.setdefault(peer, {})
        for aid in [aid for aid, a in auctions.items() if a.task_id == info.task_id]:
            del auctions[aid]
        auctions[info.auction_id] = info
        allocs = self.peer_alloc.get(peer)
        if allocs is not None and allocs.pop(info.task_id, None) is not None:
            self._unlist(info.task_id, peer)  # offered again: its earlier allocation is over

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

    def peer_handles(self, task_id: str) -> bool:
        """Does a live peer of my type run an auction for this task? Only what is fresh counts
        (`_fresh`: my memory of peers may be old)."""
        recovery = self.recovery
        board = recovery.ctx.liveness
        for peer, auctions in self.peer_open.items():
            if not recovery.peer_alive(peer):
                continue
            hb = board.last_heartbeat(recovery.name, peer)
            for a in auctions.values():
                if a.task_id == task_id and _fresh(a, hb):
                    return True
        return False

    def closed_unheard(self, peer: str) -> dict[str, Allocation]:
        """The auctions of `peer` I think open whose Close I missed (its heartbeat no longer
        lists them), taken out of `peer_open`, as allocations to the robot whose heartbeat lists
        the task (the one heard from last); an auction nobody says it holds stays open to me."""
        recovery = self.recovery
        board = recovery.ctx.liveness
        auctions = self.peer_open.get(peer, {})
        hb = board.last_heartbeat(recovery.name, peer)
        found: dict[str, Allocation] = {}
        for aid, a in list(auctions.items()):
            if _fresh(a, hb):
                continue
            holder = board.holder_of(recovery.name, a.task_id)
            if holder is not None:
                del auctions[aid]
                now = float(recovery.ctx.env.now)
                found[a.task_id] = Allocation(
                    aid, a.task_id, a.task_type, a.location, holder, now, a.search_path
                )
        return found

    def with_its_adoptions(self, peer: str) -> tuple[str, ...]:
        """A failed peer and the peers it had adopted that are still down, as its last
        heartbeat I heard said: a partner's load it inherited and fell before it noticed is
        mine too, if I adopt it (attrition with four of each, seed 52)."""
        recovery = self.recovery
        hb = recovery.ctx.liveness.last_heartbeat(recovery.name, peer)
        adopted = () if hb is None else hb.adopted
        return (peer, *(q for q in adopted if not recovery.peer_alive(q)))

    def hand_over_unheard(self, peer: str) -> dict[str, Allocation]:
        """What `peer`'s coalition partner carries for it, as far as its last heartbeat I
        heard says, if no auction I heard of allocated it: Policy 2's excavator loads its
        partner outside any auction, so only that excavator watched the transport (attrition
        seed 77: the partner fell carrying it, the excavator fell before it noticed, and the
        mineral stayed on the ground). Its task as its holder's watch, for my adoption."""
        partner = coalition_partner(peer)
        if partner is None:
            return {}
        hb = self.recovery.ctx.liveness.last_heartbeat(self.recovery.name, partner)
        if hb is None or hb.rtype != "hauler" or not hb.load or not hb.tasks:
            return {}  # (a hauler's own partner is an excavator: not a hand-over it carries)
        if hb.tasks[0] in self._alloc_peers:
            return {}
        if self.last_done.get(partner) == hb.tasks[0]:
            return {}  # delivered after that heartbeat (and gone quiet since, say)
        now = float(self.recovery.ctx.env.now)
        task_id = hb.tasks[0]  # the task of the mineral it carries
        return {
            task_id: Allocation(
                f"{peer}/coalition", task_id, "transport", (hb.x, hb.y), partner, now
            )
        }


def _fresh(a: OpenAuction, hb: Heartbeat | None) -> bool:
    """Is a peer's auction open as far as I know: announced since its last heartbeat I heard,
    or listed in it? (Else it closed and I missed its Close.)"""
    return hb is None or hb.t <= a.opened_at or a.auction_id in hb.open_auctions
