"""The typed messages robots broadcast on the bus (docs/spec.md §5–6, §10).

Plain slotted dataclasses, immutable by type (`message`): inside the engine every message is
made by the engine's own code, so checking it again cost a pydantic validation (about 3 µs) on
each of the hundred thousand messages of a scale-10 mission. Messages from outside are
validated where they arrive: field mode's `field.wire.decode` runs each through `validate`,
with the same rules (names 1-64 characters, literal statuses, no unknown fields).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Annotated, Any, Literal, TypeVar, dataclass_transform

from pydantic import ConfigDict, Field, TypeAdapter

Location = tuple[float, float]
TaskType = Literal["excavate", "transport"]
Name = Annotated[str, Field(min_length=1, max_length=64)]
M = TypeVar("M", bound="Message")
C = TypeVar("C")


@dataclass_transform(frozen_default=True, kw_only_default=True)
def message(cls: type[C]) -> type[C]:
    """A message class: slotted, keyword-only, and frozen to the type checker (mypy refuses an
    assignment to a field), not at run time. A frozen dataclass sets each field in `__init__`
    through `object.__setattr__`: 2 µs more for a heartbeat's 14 fields, 3-4 % of a scale-10
    mission (docs/benchmarks.md). One message object reaches every receiver, so nothing may
    change it; hashing by value is kept (`unsafe_hash`: safe, as nothing changes it)."""
    return dataclass(slots=True, kw_only=True, unsafe_hash=True)(cls)


@message
class Message:
    __pydantic_config__ = ConfigDict(extra="forbid")
    sender: Name

    def addressee(self) -> str | None:
        """The one robot that acts on this message, if only one does (all others ignore it)."""
        return None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields plus `type`; a -inf utility becomes None (JSON has no infinity)."""
        d = {name: getattr(self, name) for name in _field_names(type(self))}
        d["type"] = type(self).__name__.lower()
        return d


def _field_names(cls: type[Message]) -> tuple[str, ...]:
    names = _FIELD_NAMES.get(cls)
    if names is None:
        names = _FIELD_NAMES[cls] = tuple(f.name for f in fields(cls))
    return names


def validate(cls: type[M], data: Any) -> M:
    """A message from outside the engine, checked against its type (pydantic's
    `ValidationError` if it is not one); each type's validator is built once."""
    adapter = _VALIDATORS.get(cls)
    if adapter is None:
        adapter = _VALIDATORS[cls] = TypeAdapter(cls)
    msg: M = adapter.validate_python(data)
    return msg


@message
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


@message
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
        d = Message.to_dict(self)
        if not math.isfinite(self.utility):
            d["utility"] = None
        return d


@message
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


@message
class Ack(Message):
    """[auctioneer, winner, task_location, accepted|declined]."""

    auction_id: str
    auctioneer: Name
    winner: Name
    location: Location
    accepted: bool

    def addressee(self) -> str | None:
        return self.auctioneer


@message
class Close(Message):
    """[auctioneer, task_type, task_location, status=closed, allocated_to]."""

    auction_id: str
    auctioneer: Name
    task_type: TaskType
    location: Location
    task_id: str
    allocated_to: Name | None
    status: Literal["closed", "cancelled"] = "closed"


@message
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


@message
class TaskDone(Message):
    """A winner reports its task finished (or void: nothing was there)."""

    auction_id: str
    task_id: str
    outcome: Literal["done", "void", "released"] = "done"


@message
class Holding(Message):
    """'I still hold this task': answers a re-auction of a task the sender is working on."""

    task_id: str
    auction_id: str


@message
class Probe(Message):
    """'Are you there?' to a silent peer before declaring it failed; answered by a heartbeat."""

    target: Name

    def addressee(self) -> str | None:
        return self.target


@message
class Revoke(Message):
    """The auctioneer takes a task back from a robot: its earlier holder turned out alive."""

    task_id: str
    robot: Name

    def addressee(self) -> str | None:
        return self.robot


@message
class Takeover(Message):
    """A robot adopts a silent peer's auctions, monitored tasks and (scouts) its unscanned cells.
    Said again when that peer comes back, so it takes up only what nobody took over."""

    failed: Name
    cells: tuple[int, ...] = ()
    tasks: tuple[str, ...] = ()


@message
class Leaving(Message):
    """A robot disabled gracefully says goodbye so peers act without waiting for silence."""

    progress: int = 0


@message
class Hello(Message):
    """A robot joins (added or re-enabled); auctioneers re-announce their open auctions.
    A scout with no cells to scan asks for a share of the search (`wants_work`)."""

    rtype: str
    wants_work: bool = False


@message
class Handoff(Message):
    """A scout gives the far part of its unscanned route to a scout that asked for work.
    The donor keeps it pending until the receiver's heartbeat lists `handoff_id`."""

    to: Name
    cells: tuple[int, ...]
    handoff_id: str


@message
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

_FIELD_NAMES: dict[type[Message], tuple[str, ...]] = {}
_VALIDATORS: dict[type[Message], TypeAdapter[Any]] = {}
