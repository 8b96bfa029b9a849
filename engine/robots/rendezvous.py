"""The hand-over of a mineral from an excavator's bucket into a hauler's bin, as an exchange
of hand-over messages between the two robots beside each other (docs/engine-api.md).

A robot never holds the other robot: it sees the robots beside it (`Sight`, through
`Rendezvous.look` and `around`) and sends them hand-over messages by name
(`Rendezvous.send`), answered yes or no by the receiver's own `on_handover`. The exchange
is the same in both modes; only the delivery differs: in a simulated mission
(`LocalRendezvous`) a message is a call into the robot beside it, in field mode
(`field.bodies.FieldRendezvous`) a query to that robot's agent.

    taker (hauler)                              giver (excavator)
      Arrived(task_id | None: as its partner) ──▶ expects it? stands it by  ──▶ yes / no
      ◀── Here                                    (it came to the site: look again)
      ◀── Ready(free)                             standing by (and, free, holding no task)?
      ◀── Loading(transfer_s)                     a bucket is being emptied into the bin
      ◀── Transfer(task_id)                       the mineral moves now, iff the taker can
                                                  receive and the witness records the move
      Left ──────────────────────────────────▶   the partner leaves the site

The hand-over messages are not radio messages: two robots a metre apart meet, so they are
neither lost nor logged (the bus, `engine.bus`, carries the auctions and heartbeats).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from engine.geometry import Point, dist
from engine.terrain import NEAR


@dataclass(frozen=True)
class Arrived:
    """Taker → giver: I came for this transport (None: as your coalition partner)."""

    task_id: str | None


@dataclass(frozen=True)
class Left:
    """Taker → giver: your coalition partner leaves your site."""


@dataclass(frozen=True)
class Here:
    """Giver → a taker waiting at the site: I have come; look again."""


@dataclass(frozen=True)
class Ready:
    """Giver → taker: do you stand by for my bucket (`free`: and hold no task)?"""

    free: bool


@dataclass(frozen=True)
class Loading:
    """Giver → taker: my bucket is being emptied into your bin; it takes `transfer_s`."""

    transfer_s: float


@dataclass(frozen=True)
class Transfer:
    """Giver → taker: the mineral of transport `task_id` moves into your bin now."""

    task_id: str


Handover = Arrived | Left | Here | Ready | Loading | Transfer

Witness = Callable[[], bool]
"""The record of a mineral's move, asked by the taker once it can receive and before it
takes: True once the move is recorded (exactly once), False if it never will be."""


def recorded() -> bool:
    """A simulated mission's witness: the field is in this process, the move is the record."""
    return True


@dataclass(frozen=True)
class Sight:
    """What a robot sees of another one: who, where, and what an excavator waits to load."""

    name: str
    rtype: str
    alive: bool
    pos: Point
    ahead: tuple[str, ...] = ()
    waiting_for: str | None = None

    def expects(self, task_id: str) -> bool:
        """Is this transport for the mineral in its bucket, or one it is about to dig?"""
        return task_id == self.waiting_for or task_id in self.ahead


def sight_of(robot: Any) -> Sight:
    """What a robot looks like from beside it (a robot object or a stand-in for one)."""
    return Sight(
        robot.name,
        robot.rtype,
        bool(robot.alive),
        robot.pos,
        tuple(getattr(robot, "ahead", ())),
        getattr(robot, "waiting_for", None),
    )


class Party(Protocol):
    """A robot that takes part in hand-overs (`Excavator`, `Hauler`)."""

    name: str

    def on_handover(self, sender: Sight, msg: Handover, witness: Witness) -> bool: ...


class Rendezvous:
    """Where robots beside each other see each other and exchange hand-over messages. The
    robots present are read through `robots` (the mission's, or field stand-ins)."""

    def __init__(self, robots: Mapping[str, Any]) -> None:
        self._robots = robots

    def look(self, name: str) -> Sight | None:
        r = self._robots.get(name)
        return None if r is None else sight_of(r)

    def around(self, pos: Point, rtype: str, *, living: bool = True) -> list[Sight]:
        """The robots of a type within reach of `pos` (only living ones, unless told)."""
        return [
            sight_of(r)
            for r in self._robots.values()
            if r.rtype == rtype and (not living or r.alive) and dist(r.pos, pos) <= NEAR
        ]

    def send(self, sender: Any, to: str, msg: Handover) -> bool:
        """Deliver `msg` from robot `sender` to the robot named `to`; its answer."""
        raise NotImplementedError


class LocalRendezvous(Rendezvous):
    """A simulated mission's: the receiver is in this process, a message is a call."""

    def send(self, sender: Any, to: str, msg: Handover) -> bool:
        receiver = self._robots.get(to)
        handle = getattr(receiver, "on_handover", None)
        return handle is not None and bool(handle(sight_of(sender), msg, recorded))
