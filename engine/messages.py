"""The typed, validated messages robots broadcast on the bus (docs/spec.md §5–6, §10)."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

Location = tuple[float, float]
TaskType = Literal["excavate", "transport"]
Name = Annotated[str, Field(min_length=1, max_length=64)]


class Message(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")
    sender: Name

    def addressee(self) -> str | None:
        """The one robot that acts on this message, if only one does (all others ignore it)."""
        return None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields plus `type`; a -inf utility becomes None (JSON has no infinity)."""
        d = dict(self.__dict__)
        d["type"] = type(self).__name__.lower()
        return d


class Announce(Message):
    """[auctioneer, task_type, task_location, status=open]: a task is up for bids."""

    auction_id: str
    auctioneer: Name
    task_type: TaskType
    location: Location
    task_id: str
    opened_at: float
    round: int = 0
    status: Literal["open"] = "open"
    search_path: tuple[Location, ...] = ()


class Bid(Message):
    """[auctioneer, bidder, task_location, utility]; utility -inf means 'busy'."""

    auction_id: str
    auctioneer: Name
    bidder: Name
    location: Location
    utility: float
    round: int

    def addressee(self) -> str | None:
        return self.auctioneer

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        if not math.isfinite(self.utility):
            d["utility"] = None
        return d


class Award(Message):
    """[auctioneer, task_type, task_location, status=open, winner]."""

    auction_id: str
    auctioneer: Name
    task_type: TaskType
    location: Location
    winner: Name
    status: Literal["open"] = "open"

    def addressee(self) -> str | None:
        return self.winner


class Ack(Message):
    """[auctioneer, winner, task_location, accepted|declined]."""

    auction_id: str
    auctioneer: Name
    winner: Name
    location: Location
    accepted: bool

    def addressee(self) -> str | None:
        return self.auctioneer


class Close(Message):
    """[auctioneer, task_type, task_location, status=closed, allocated_to]."""

    auction_id: str
    auctioneer: Name
    task_type: TaskType
    location: Location
    task_id: str
    allocated_to: Name | None
    status: Literal["closed", "cancelled"] = "closed"


class Heartbeat(Message):
    """Liveness and progress: what the robot holds, where it is, how far its scan has come."""

    rtype: str
    t: float
    x: float
    y: float
    state: str
    tasks: tuple[str, ...] = ()
    open_auctions: tuple[str, ...] = ()
    progress: int = 0
    path: tuple[Location, ...] = ()
    load: int = 0
    done: tuple[str, ...] = ()
    adopted: tuple[str, ...] = ()
    received: tuple[str, ...] = ()


class TaskDone(Message):
    """A winner reports its task finished (or void: nothing was there)."""

    auction_id: str
    task_id: str
    outcome: Literal["done", "void", "released"] = "done"


class Holding(Message):
    """'I still hold this task': answers a re-auction of a task the sender is working on."""

    task_id: str
    auction_id: str


class Probe(Message):
    """'Are you there?' to a silent peer before declaring it failed; answered by a heartbeat."""

    target: Name

    def addressee(self) -> str | None:
        return self.target


class Revoke(Message):
    """The auctioneer takes a task back from a robot: its earlier holder turned out alive."""

    task_id: str
    robot: Name

    def addressee(self) -> str | None:
        return self.robot


class Takeover(Message):
    """A robot adopts a silent peer's auctions, monitored tasks and (scouts) its unscanned cells.
    Said again when that peer comes back, so it takes up only what nobody took over."""

    failed: Name
    cells: tuple[int, ...] = ()
    tasks: tuple[str, ...] = ()


class Leaving(Message):
    """A robot disabled gracefully says goodbye so peers act without waiting for silence."""

    progress: int = 0


class Hello(Message):
    """A robot joins (added or re-enabled); auctioneers re-announce their open auctions.
    A scout with no cells to scan asks for a share of the search (`wants_work`)."""

    rtype: str
    wants_work: bool = False


class Handoff(Message):
    """A scout gives the far part of its unscanned route to a scout that asked for work.
    The donor keeps it pending until the receiver's heartbeat lists `handoff_id`."""

    to: Name
    cells: tuple[int, ...]
    handoff_id: str


class PolicyChange(Message):
    """The operator switched the allocation policy."""

    policy: str


ALL_MESSAGES: tuple[type[Message], ...] = (
    Announce,
    Bid,
    Award,
    Ack,
    Close,
    Heartbeat,
    TaskDone,
    Holding,
    Probe,
    Revoke,
    Takeover,
    Leaving,
    Hello,
    Handoff,
    PolicyChange,
)
