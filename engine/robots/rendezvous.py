"""The hand-over of a mineral from an excavator's bucket into a hauler's bin, as each side
sees the other beside it. Both robot types are written against these interfaces, not
against each other's class; field mode's stand-in for a robot in another process
(`field.remote.PeerBody`) offers the same calls over the network."""

from __future__ import annotations

from typing import Protocol

from engine.geometry import Point


class Giver(Protocol):
    """An excavator as a hauler beside it sees it and acts on it."""

    name: str

    @property
    def alive(self) -> bool: ...
    @property
    def pos(self) -> Point: ...
    @property
    def ahead(self) -> list[str]:
        """The transports auctioned ahead of minerals it is still to dig, next first."""
        ...

    @property
    def transfer_now_s(self) -> float:
        """How long the transfer under way takes."""
        ...

    def expects(self, task_id: str) -> bool: ...
    def hauler_arrived(self, hauler: Taker, task_id: str) -> bool: ...
    def partner_arrived(self, hauler: Taker) -> None: ...
    def partner_left(self, hauler: Taker) -> None: ...


class Taker(Protocol):
    """A hauler as an excavator beside it sees it and acts on it."""

    name: str
    loading_from: Giver | None  # a bucket is being emptied into its bin

    def can_receive(self, exc: Giver) -> bool: ...
    def receive(self, exc: Giver, task_id: str) -> None: ...
    def ready_for(self, exc: Giver) -> bool: ...
    def standing_by(self, exc: Giver) -> bool: ...
