"""Turns what a live mission produced since the last call into database rows.

Pure bookkeeping, called by the live runner on the event loop while it holds the engine's
gate (`app/live/gate.py`), so no step runs meanwhile: it reads the engine's append-only event
log and auction records by cursor and remembers how many bids and awards each auction already
has stored, so a batch holds only new rows and the auctions whose outcome changed. A field
mission also hands over its robots' reported poses (`PoseSource`): a field run is played back
from them; a simulated one stores none (replay rebuilds it).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

from engine import AuctionView, MissionInterface


@dataclass
class Batch:
    """New rows for one mission, written in one transaction."""

    mission_id: int
    sim_time: float
    events: list[dict[str, Any]] = field(default_factory=list)
    new_auctions: list[dict[str, Any]] = field(default_factory=list)
    changed_auctions: list[dict[str, Any]] = field(default_factory=list)
    bids: list[dict[str, Any]] = field(default_factory=list)
    awards: list[dict[str, Any]] = field(default_factory=list)
    changed_awards: list[dict[str, Any]] = field(default_factory=list)
    poses: list[dict[str, Any]] = field(default_factory=list)

    def __len__(self) -> int:
        return (
            len(self.events) + len(self.new_auctions) + len(self.changed_auctions) + len(self.poses)
        )


@runtime_checkable
class PoseSource(Protocol):
    """A mission whose robots report their poses (`field.control.FieldMission`)."""

    def take_poses(self) -> list[dict[str, Any]]:
        """The poses reported since the last call, each `{"robot", "t", "x", "y", "heading",
        "state", "load"}`."""


def auction_row(mission_id: int, d: dict[str, Any]) -> dict[str, Any]:
    """The auctions-table row for an `AuctionRecord.to_dict()`."""
    x, y = d["location"]
    return {
        "mission_id": mission_id,
        "auction_id": d["id"],
        "kind": d["kind"],
        "auctioneer": d["auctioneer"],
        "task_type": d["task_type"],
        "location_x": float(x),
        "location_y": float(y),
        "status": d["status"],
        "opened_at": d["opened_at"],
        "closed_at": d.get("closed_at"),
        "allocated_to": d.get("allocated_to"),
        "reannouncements": d.get("reannouncements", 0),
        "policy": d["policy"],
        "task_id": d.get("task_id"),
        "reauction_of": d.get("reauction_of"),
    }


@dataclass
class Stored:
    """What the database already holds for a mission (all zero for a new one)."""

    events: int = 0
    bids: dict[str, int] = field(default_factory=dict)
    awards: dict[str, list[str]] = field(default_factory=dict)  # outcomes, by index


class Recorder:
    """Diffs one mission (simulated or field) against what was already written."""

    def __init__(
        self, mission_id: int, mission: MissionInterface, stored: Stored | None = None
    ) -> None:
        stored = stored or Stored()
        self.mission_id = mission_id
        self.mission = mission
        self._events = stored.events
        self._bids = dict(stored.bids)
        self._awards = {aid: list(outcomes) for aid, outcomes in stored.awards.items()}
        self._index: dict[str, AuctionView] = {}
        self._seen_auctions = 0
        # Open auctions and pending offers may still change: after a restart, check once every
        # auction stored and every one the replayed mission holds. A crash between a batch's
        # event chunks and its last transaction leaves auctions whose opening events are
        # stored (so no new event names them) and whose rows are not.
        self._watch: set[str] = set(stored.bids) | {rec.id for rec in mission.auctions}

    def _auction(self, auction_id: str) -> AuctionView | None:
        auctions = self.mission.auctions
        if len(auctions) != self._seen_auctions or auction_id not in self._index:
            for rec in auctions[self._seen_auctions :]:
                self._index[rec.id] = rec
            self._seen_auctions = len(auctions)
        return self._index.get(auction_id)

    @property
    def pending(self) -> int:
        """Events produced but not yet collected."""
        return len(self.mission.events) - self._events

    def collect(self) -> Batch:
        """Everything new since the previous call."""
        m = self.mission
        log = m.events
        fresh = log[self._events :]
        self._events = len(log)
        batch = Batch(self.mission_id, float(m.now))
        if isinstance(m, PoseSource):
            batch.poses = [{"mission_id": self.mission_id, **p} for p in m.take_poses()]
        dirty: set[str] = set()
        # a field run's: the process life that reported each event, and its number there
        origins: dict[int, tuple[str, int]] = getattr(m, "origins", None) or {}
        for ev in fresh:
            source, rseq = origins.pop(ev.seq, (None, None))
            batch.events.append(
                {
                    "mission_id": self.mission_id,
                    "seq": ev.seq,
                    "t": ev.t,
                    "kind": ev.kind,
                    "data": ev.data,
                    "source": source,
                    "rseq": rseq,
                }
            )
            aid = ev.data.get("auction_id") if isinstance(ev.data, dict) else None
            if isinstance(aid, str):
                dirty.add(aid)
        for aid in sorted(dirty | self._watch):
            rec = self._auction(aid)
            if rec is not None:
                self._add_auction(batch, rec.to_dict())
        return batch

    def _add_auction(self, batch: Batch, d: dict[str, Any]) -> None:
        aid = d["id"]
        if d["status"] == "open" or any(a["outcome"] == "pending" for a in d.get("awards", [])):
            self._watch.add(aid)
        else:
            self._watch.discard(aid)
        row = auction_row(self.mission_id, d)
        if aid in self._bids:
            batch.changed_auctions.append(row)
        else:
            batch.new_auctions.append(row)
            self._bids[aid] = 0
            self._awards[aid] = []
        for i, b in enumerate(d.get("bids", [])[self._bids[aid] :], start=self._bids[aid]):
            batch.bids.append(
                {
                    "mission_id": self.mission_id,
                    "auction_id": aid,
                    "idx": i,
                    "t": b["t"],
                    "bidder": b["bidder"],
                    "utility": b.get("utility"),
                    "round": b.get("round", 0),
                }
            )
        self._bids[aid] = len(d.get("bids", []))
        stored = self._awards[aid]
        for i, a in enumerate(d.get("awards", [])):
            if i >= len(stored):  # a new offer
                batch.awards.append(
                    {
                        "mission_id": self.mission_id,
                        "auction_id": aid,
                        "idx": i,
                        "t": a["t"],
                        "winner": a["winner"],
                        "outcome": a["outcome"],
                    }
                )
                stored.append(a["outcome"])
            elif stored[i] != a["outcome"]:  # an offer answered since (pending → accepted)
                batch.changed_awards.append(
                    {
                        "mission_id": self.mission_id,
                        "auction_id": aid,
                        "idx": i,
                        "outcome": a["outcome"],
                    }
                )
                stored[i] = a["outcome"]
