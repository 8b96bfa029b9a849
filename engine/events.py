"""Immutable event records: the engine's only output; persistence and streaming subscribe."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True)
class Event:
    seq: int
    t: float
    kind: str
    data: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        return {"seq": self.seq, "t": self.t, "kind": self.kind, "data": self.data}


Subscriber = Callable[[Event], None]


class EventLog:
    """The ordered log of one run; numbering is the order events happen in."""

    def __init__(self, clock: Callable[[], float]) -> None:
        self._clock = clock
        self.events: list[Event] = []
        self.keep = True
        self.emitted = 0
        self._subscribers: list[Subscriber] = []
        self._readers = 0  # subscribers that read payloads
        self.counts: dict[str, int] = {}

    def stream_only(self) -> None:
        """Hand events to the subscribers without keeping them: a headless run reads only
        its metrics, and at scale the log is most of a mission's memory (a scale-100 run
        makes millions of events nobody reads back during it)."""
        if self.emitted:
            raise RuntimeError("stream_only: events were already kept")
        self.keep = False

    def subscribe(self, fn: Subscriber, *, payloads: bool = True) -> None:
        """`payloads` False: `fn` reads only an event's kind and time, and never one of a kind
        counted without its payload (`count_unread`)."""
        self._subscribers.append(fn)
        if payloads:
            self._readers += 1

    @property
    def unread(self) -> bool:
        """Nobody will read an event's payload: the log keeps none and no subscriber reads
        them (a headless run, which reads only its metrics)."""
        return not self.keep and not self._readers

    def count_unread(self, kind: str) -> None:
        """An event of `kind` that nobody reads (`unread`): numbered and counted like every
        other, without building it (a scale-100 run records millions of messages)."""
        self.emitted += 1
        counts = self.counts
        counts[kind] = counts.get(kind, 0) + 1

    def emit(self, kind: str, /, **data: Any) -> Event:
        return self.append(kind, data)

    def append(self, kind: str, data: dict[str, Any]) -> Event:
        """`emit` with the payload already a dict (taken over, not copied)."""
        return self.append_at(self._clock(), kind, data)

    def append_at(self, t: float, kind: str, data: dict[str, Any]) -> Event:
        """`append` of an event that happened at `t`, elsewhere: field mode's mission control
        logs what its robots report, each at the time it happened on the robot's clock."""
        ev = Event(self.emitted, t, kind, data)
        self.emitted += 1
        if self.keep:
            self.events.append(ev)
        counts = self.counts
        counts[kind] = counts.get(kind, 0) + 1
        for fn in self._subscribers:
            fn(ev)
        return ev
