"""What a robot does with each message it hears: the table that hands every message to the
robot's part it concerns (`HANDLERS`, read by `Robot.on_message`), and the ideal bus's first
look at a re-announcement (`first_look`), which spares a busy robot the handler's path."""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, Any, Protocol

from engine.auction_rules import Allocation
from engine.bidding import OpenAuction
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
from engine.robots.core import Assignment
from engine.round_board import Rounds

if TYPE_CHECKING:
    import simpy

    from engine.auction_house import AuctionHouse
    from engine.context import MissionContext
    from engine.robots.bidder import Bidder
    from engine.robots.recovery import Recovery
    from engine.robots.search import Search


class HearingRobot(Protocol):
    """What hearing a message reads and changes of its robot."""

    name: str
    rtype: str
    ctx: MissionContext
    env: simpy.Environment
    alive: bool
    current: Assignment | None
    queue: deque[Assignment]
    rounds: Rounds
    recovery: Recovery
    house: AuctionHouse
    bidder: Bidder | None
    search: Search | None

    @property
    def capability(self) -> TaskType | None: ...
    def assign(self, a: Assignment) -> None: ...
    def on_close_heard(self, msg: Close) -> None: ...


def first_look(robot: HearingRobot, msg: Announce) -> bool:
    """The ideal bus's shortcut for an announcement (`EmbeddedBus.subscribe`): answers True
    when hearing it would only update `rounds` (a later round of an auction I know, of a
    task I neither hold nor finished, that leaves my bidder quiet) and notes the round
    here; anything else is False and goes to `_on_announce` as usual.

    `rounds` is where my knowledge of an announced auction lives (its latest round, read
    when I bid); `bidder.biddable` holds those I could serve. Both are written exactly as
    `_on_announce` would: this only spares a busy robot the handler's path."""
    why = only_notes(robot, msg)
    if why == "note":
        robot.rounds.note(msg.auction_id, msg.round)
    return why is not None


def only_notes(robot: HearingRobot, msg: Announce) -> str | None:
    """`first_look` without its effect: None when the handler must hear the announcement,
    else why not ("dead": I hear nothing; "note": I would only note its round). The board of
    rounds (engine/round_board.py) asks it of the robots it skips, when checking itself."""
    if not robot.alive:
        return "dead"  # hears nothing (`on_message`)
    aid = msg.auction_id
    if aid not in robot.rounds:
        return None  # a new auction to me
    task_id = msg.task_id
    if task_id in robot.recovery.completed:
        return None  # I say it is done
    if _holds(robot, task_id):
        return None  # I say I hold it
    bidder = robot.bidder
    if bidder is not None and aid in bidder.biddable and not bidder.stays_quiet():
        return None  # the new round may draw a bid from me
    return "note"


def _on_announce(robot: HearingRobot, msg: Announce) -> None:
    task_id, aid = msg.task_id, msg.auction_id
    recovery, bidder, rounds = robot.recovery, robot.bidder, robot.rounds
    if task_id in recovery.completed:
        # offered again from an old record (a watcher back from a failure that missed my
        # TaskDone): it is done, say so again and the auctioneer withdraws it
        rounds.keep(aid)
        robot.ctx.bus.publish(
            TaskDone(sender=robot.name, auction_id=aid, task_id=task_id, outcome="done")
        )
        return
    if _holds(robot, task_id):
        rounds.keep(aid)
        robot.ctx.bus.publish(Holding(sender=robot.name, task_id=task_id, auction_id=aid))
        return
    if aid in rounds:  # a re-announcement: only the round is new
        rounds.note(aid, msg.round)
        if bidder is not None and aid in bidder.biddable:
            bidder.consider_bids()
        return
    rounds.note(aid, msg.round)
    info = OpenAuction(
        aid,
        msg.auctioneer,
        msg.task_type,
        msg.location,
        task_id,
        msg.opened_at,
        msg.search_path,
    )
    if recovery.peer_type(msg.sender) == robot.rtype:
        recovery.peer_duties.note_peer_open(msg.sender, info)
    # a duplicate auction for a task I am auctioning: the smaller name keeps it
    robot.house.yield_duplicate(aid, task_id, msg.sender)
    if robot.search is not None:  # scouts learn of sites their peers found
        robot.search.on_task_heard(msg.task_type, task_id)
    if bidder is not None and msg.task_type == robot.capability:
        bidder.note_auction(info)
        bidder.consider_bids()


def _holds(robot: HearingRobot, task_id: str) -> bool:
    cur = robot.current
    return (cur is not None and cur.task_id == task_id) or (
        bool(robot.queue) and any(a.task_id == task_id for a in robot.queue)
    )


def _on_close(robot: HearingRobot, msg: Close) -> None:
    if msg.allocated_to not in (None, robot.name) and _holds(robot, msg.task_id):
        # my task given to another: my Holding to its announcement was lost (or came after
        # the award). Said again, the auctioneer revokes the other (`holder_says`).
        robot.ctx.bus.publish(
            Holding(sender=robot.name, task_id=msg.task_id, auction_id=msg.auction_id)
        )
    bidder = robot.bidder
    if bidder is None:
        robot.rounds.forget(msg.auction_id)
        info = None
    else:
        info = bidder.closed(msg.auction_id)
    peer = robot.recovery.peer_duties.peer_open.get(msg.sender)
    if peer is not None:
        peer.pop(msg.auction_id, None)
        if msg.allocated_to is not None:
            robot.recovery.peer_duties.note_peer_alloc(
                msg.sender,
                Allocation(
                    msg.auction_id,
                    msg.task_id,
                    msg.task_type,
                    msg.location,
                    msg.allocated_to,
                    float(robot.env.now),
                ),
            )
    robot.on_close_heard(msg)
    if bidder is None:
        return
    reserved = bidder.reserved
    if reserved is not None and reserved.auction_id == msg.auction_id:
        bidder.let_go()
        if msg.allocated_to == robot.name and robot.alive:
            robot.assign(
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
        bidder.consider_bids()


def _on_bid(robot: HearingRobot, msg: Bid) -> None:
    if msg.auctioneer == robot.name:
        robot.house.on_bid(msg)


def _on_ack(robot: HearingRobot, msg: Ack) -> None:
    if msg.auctioneer == robot.name:
        robot.house.on_ack(msg)


def _on_award(robot: HearingRobot, msg: Award) -> None:
    if robot.bidder is not None:
        robot.bidder.on_award(msg)


HANDLERS: dict[type[Message], Any] = {
    Announce: _on_announce,
    Bid: _on_bid,
    Award: _on_award,
    Ack: _on_ack,
    Close: _on_close,
    TaskDone: lambda robot, msg: robot.recovery.on_task_done(msg),
    Holding: lambda robot, msg: robot.recovery.on_holding(msg),
    Takeover: lambda robot, msg: robot.recovery.on_takeover(msg),
    Leaving: lambda robot, msg: robot.recovery.on_leaving(msg),
    Hello: lambda robot, msg: robot.recovery.on_hello(msg),
    Handoff: lambda robot, msg: robot.search and robot.search.on_handoff_heard(msg),
    Probe: lambda robot, msg: robot.recovery.on_probe(msg),
    Revoke: lambda robot, msg: robot.recovery.on_revoke(msg),
}
