"""What mission control takes in from a field mission's key space, checked.

Every protocol message is opened like a robot opens it (`field.transport.open_message`), and
every event, auction record and pose an agent reports must be signed by that agent, be about
itself (an auction record only of an auction it holds, an event or a pose only in its own
name, a pose only from a robot with a body) and have the shape the service stores
(`ReportedAuction`, `ReportedEvent`, `ReportedPose`). What fails is dropped
and counted: nothing a robot sends can put a record in front of the service that the
service cannot store, or that another robot should have sent.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from engine.messages import Heartbeat
from engine.team import robot_type
from field.journal import source_of
from field.link import Link
from field.transport import open_message
from field.trust import MAX_REPORT, WORLD, Rejected
from field.wire import event_key

Name = Annotated[str, Field(pattern=r"^[A-Za-z0-9_.\-]{1,64}$")]
Time = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Coordinate = Annotated[float, Field(allow_inf_nan=False, ge=-1e6, le=1e6)]
Short = Annotated[str, Field(min_length=1, max_length=128)]
AHEAD_MAX = 64
"""Reports of one life held while an earlier one is missing, and how far past it (further
ones are read back from its journal once the gap is filled). Small: a report may be 1 MiB,
and a robot with a stolen credential must not fill the server's memory with held ones."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)


class ReportedBid(_Strict):
    t: Time
    bidder: Name
    utility: Annotated[float, Field(allow_inf_nan=False)] | None
    round: Annotated[int, Field(ge=0, le=1_000_000)]


class ReportedAward(_Strict):
    t: Time
    winner: Name
    outcome: Literal["pending", "accepted", "declined", "timeout", "withdrawn"]


class ReportedAuction(_Strict):
    """`engine.auction_rules.AuctionRecord.to_dict()`, as an agent reports it."""

    id: Short
    kind: Short
    auctioneer: Name
    task_type: Literal["excavate", "transport"]
    task_id: Short
    location: tuple[Coordinate, Coordinate]
    status: Literal["open", "closed", "cancelled", "superseded"]
    opened_at: Time
    closed_at: Time | None
    allocated_to: Name | None
    reannouncements: Annotated[int, Field(ge=0, le=1_000_000)]
    reauction_of: Short | None
    policy: Short
    bids: Annotated[list[ReportedBid], Field(max_length=10_000)]
    awards: Annotated[list[ReportedAward], Field(max_length=10_000)]


class ReportedEvent(_Strict):
    kind: Literal["event"]
    t: Time
    event: Annotated[str, Field(pattern=r"^[a-z_]{1,40}$")]
    data: Annotated[dict[str, Any], Field(max_length=64)]
    by: Name

    @field_validator("data")
    @classmethod
    def _json(cls, v: dict[str, Any]) -> dict[str, Any]:
        """Stored as JSON: no NaN or infinity anywhere in it."""
        json.dumps(v, allow_nan=False)
        return v


class ReportedPose(_Strict):
    """A robot's own pose at mission time `t` (`field.agent.Agent._report_poses`), stored
    for playback. Strict: JSON numbers are numbers, never strings or booleans."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    kind: Literal["pose"]
    t: Time
    x: Coordinate
    y: Coordinate
    heading: Annotated[float, Field(allow_inf_nan=False, ge=-10.0, le=10.0)]  # radians
    state: Annotated[str, Field(pattern=r"^[a-z_]{1,32}$")]
    load: Annotated[int, Field(ge=0, le=64)]
    by: Name | None = None  # (optional: the signer is the robot)


@dataclass
class Intake:
    """Everything mission control hears: protocol messages (checked, counted), events and
    auction records (the latest version of each auction), the robots' poses (until the
    mission takes them: `FieldMission._take_in`), and what the agents dropped."""

    link: Link
    messages: int = 0
    by_type: dict[str, int] = field(default_factory=dict)
    events: list[dict[str, Any]] = field(default_factory=list)
    heartbeats: dict[str, Heartbeat] = field(default_factory=dict)  # the last, by sender
    auctions: dict[str, dict[str, Any]] = field(default_factory=dict)
    poses: list[dict[str, Any]] = field(default_factory=list)  # {"robot", "t", ...}, not taken yet
    agents_dropped: dict[str, int] = field(default_factory=dict)  # by agent, its own count
    lock: threading.Lock = field(default_factory=threading.Lock)
    on_heard: Callable[[str, tuple[float, float] | None], None] | None = None
    # the world service's events: in this process (`on_world_event`) or heard on the bus
    world_on_bus: bool = False
    # each life's next report number: its reports are taken in order, each once
    next_rseq: dict[str, int] = field(default_factory=dict)
    _ahead: dict[str, dict[int, dict[str, Any]]] = field(default_factory=dict)
    repeats: int = 0  # reports heard again (the bus and the journal both had them)
    _order: threading.Lock = field(default_factory=threading.Lock)

    @property
    def malformed(self) -> int:
        """Frames mission control dropped (unsigned, forged, malformed, not allowed...)."""
        return self.link.opener.rejections.total

    def rejections(self) -> dict[str, Any]:
        """What this mission's processes dropped: mission control's own count (by reason and
        sender), and each agent's as it last reported it."""
        with self.lock:
            agents = dict(sorted(self.agents_dropped.items()))
        mine = self.link.rejections
        return {**mine, "agents": agents, "total": mine["total"] + sum(agents.values())}

    def on_message(self, sample: Any) -> None:
        msg = open_message(self.link, str(sample.key_expr), sample.payload.to_bytes())
        if msg is None:
            return
        with self.lock:
            self.messages += 1
            kind = type(msg).__name__.lower()
            self.by_type[kind] = self.by_type.get(kind, 0) + 1
            if isinstance(msg, Heartbeat):
                self.heartbeats[msg.sender] = msg
        if self.on_heard is not None:
            self.on_heard(msg.sender, (msg.x, msg.y) if isinstance(msg, Heartbeat) else None)

    def _report_channel(self, signer: str) -> str:
        """A report is signed for its signer's own event key, whatever key Zenoh hands it
        over with."""
        return event_key(self.link.mission, signer)

    def on_report(self, sample: Any) -> None:
        got = self.link.open_json(self._report_channel, sample.payload.to_bytes(), MAX_REPORT)
        if got is None:
            return
        opened, data = got
        if opened.sender == WORLD and not self.world_on_bus:
            return  # the world service's own events: taken in once, by `on_world_event`
        if data.get("kind") == "rejections":  # a count, not a record: the latest one counts
            self._take_checked(opened.sender, "", data, opened.cert.role)
        else:
            self.offer(opened.sender, opened.cert.gen, data, opened.cert.role)

    def offer(self, sender: str, gen: int, data: dict[str, Any], role: str = "") -> None:
        """A numbered report of `sender`'s life `gen`, heard on the bus or read back from its
        journal: taken in number order, once (a later one waits for the ones before it,
        which the journal fills in: `behind`)."""
        rseq = data.get("rseq")
        if type(rseq) is not int or not 0 <= rseq < 2**53:
            self.link.opener.rejections.count(Rejected("invalid report", sender, "rseq"))
            return
        src = source_of(sender, gen)
        with self._order:
            nxt = self.next_rseq.get(src, 0)
            if rseq < nxt:
                self.repeats += 1
                return
            ahead = self._ahead.setdefault(src, {})
            if rseq > nxt:
                if rseq - nxt <= AHEAD_MAX and len(ahead) < AHEAD_MAX:
                    ahead[rseq] = data
                return
            self._take_checked(sender, src, data, role)
            nxt += 1
            while nxt in ahead:
                self._take_checked(sender, src, ahead.pop(nxt), role)
                nxt += 1
            self.next_rseq[src] = nxt

    def behind(self) -> dict[str, int]:
        """The lives with reports missing before ones already heard: where to read from."""
        with self._order:
            return {src: self.next_rseq.get(src, 0) for src, ahead in self._ahead.items() if ahead}

    def _take_checked(self, sender: str, src: str, data: dict[str, Any], role: str = "") -> None:
        """Taken, or counted as rejected: either way its number is used up. (`role`: the
        certificate's; a report read back from a journal has the one its name was issued.)"""
        try:
            data = {**data, "src": src} if data.get("kind") in ("event", "pose") else data
            self.take(sender, data, role or robot_type(sender))
        except Rejected as exc:
            self.link.opener.rejections.count(exc)
        except (ValidationError, ValueError, TypeError) as exc:
            detail = str(exc).splitlines()[0]
            if isinstance(exc, ValidationError) and exc.errors():
                first = exc.errors()[0]
                detail = f"{'.'.join(map(str, first['loc']))}: {first['msg']}"
            self.link.opener.rejections.count(Rejected("invalid report", sender, detail))

    def take(self, sender: str, data: dict[str, Any], role: str = "") -> None:
        """One checked report from agent `sender`, of certified `role` (Rejected or
        ValidationError otherwise)."""
        kind = data.get("kind")
        if kind == "auction":
            rec = ReportedAuction.model_validate(data.get("record")).model_dump(mode="json")
            if rec["auctioneer"] != sender or not rec["id"].startswith(f"{sender}/"):
                raise Rejected("impersonation", sender, f"auction {rec['id']!r}")
            with self.lock:
                self.auctions[rec["id"]] = rec
        elif kind == "event":
            fields = {k: v for k, v in data.items() if k not in ("v", "src", "rseq")}
            ev = ReportedEvent.model_validate(fields).model_dump(mode="json")
            if ev["by"] != sender or (sender != WORLD and ev["data"].get("by", sender) != sender):
                raise Rejected("impersonation", sender, f"event {ev['event']!r}")
            ev["src"], ev["rseq"] = data.get("src"), data.get("rseq")
            with self.lock:
                self.events.append(ev)
        elif kind == "pose":
            fields = {k: v for k, v in data.items() if k not in ("v", "src", "rseq")}
            pose = ReportedPose.model_validate(fields).model_dump(exclude={"kind", "by"})
            if fields.get("by", sender) != sender:
                raise Rejected("impersonation", sender, "pose")
            if role == "operator":
                raise Rejected("not allowed", sender, "a pose of the operator's console")
            pose["source"], pose["rseq"] = data.get("src"), data.get("rseq")
            with self.lock:
                self.poses.append({"robot": sender, **pose})
        elif kind == "rejections":
            total = data.get("total")
            if not isinstance(total, int) or not 0 <= total < 2**53:
                raise Rejected("invalid report", sender, "rejections")
            with self.lock:
                self.agents_dropped[sender] = total
        else:
            raise Rejected("invalid report", sender, f"kind {str(kind)[:40]!r}")

    def on_world_event(self, data: dict[str, Any]) -> None:
        """The world service's own events (mission control's process: trusted)."""
        with self.lock:
            self.events.append(data)


class RecordView:
    """An auction as mission control last heard of it (`AuctionRecord`'s reading side)."""

    def __init__(self, records: dict[str, dict[str, Any]], auction_id: str) -> None:
        self._records, self.id = records, auction_id

    def to_dict(self) -> dict[str, Any]:
        return dict(self._records[self.id])

    @property
    def status(self) -> str:
        return str(self._records[self.id]["status"])

    @property
    def reannouncements(self) -> int:
        return int(self._records[self.id].get("reannouncements") or 0)
