"""The recorder turns an engine's append-only log into new rows and outcome updates."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from app.live.recorder import Recorder, Stored


@dataclass
class Ev:
    seq: int
    t: float
    kind: str
    data: dict[str, Any]


@dataclass
class Rec:
    id: str
    d: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        return self.d


@dataclass
class FakeMission:
    now: float = 0.0
    events: list[Ev] = field(default_factory=list)
    auctions: list[Rec] = field(default_factory=list)


def _auction(status: str, bids: list[dict[str, Any]], awards: list[dict[str, Any]]) -> dict:
    return {
        "id": "scout-1/1",
        "kind": "scout_excavator",
        "auctioneer": "scout-1",
        "task_type": "excavate",
        "location": [1.0, 2.0],
        "status": status,
        "opened_at": 1.0,
        "closed_at": None if status == "open" else 3.0,
        "allocated_to": None if status == "open" else "excavator-1",
        "reannouncements": 0,
        "policy": "fcfs",
        "bids": bids,
        "awards": awards,
    }


def test_new_rows_then_only_changes() -> None:
    m = FakeMission()
    rec = Recorder(7, m)
    bid = {"t": 1.5, "bidder": "excavator-1", "utility": None, "round": 0}
    m.auctions.append(Rec("scout-1/1", _auction("open", [bid], [])))
    m.events += [Ev(0, 1.0, "auction_opened", {"auction_id": "scout-1/1"}), Ev(1, 1.5, "bid", {})]
    m.now = 1.5
    first = rec.collect()
    assert [e["seq"] for e in first.events] == [0, 1] and first.sim_time == 1.5
    assert len(first.new_auctions) == 1 and first.new_auctions[0]["mission_id"] == 7
    assert first.bids[0]["utility"] is None and not first.awards

    offer = {"t": 2.0, "winner": "excavator-1", "outcome": "pending"}
    m.auctions[0].d = _auction("open", [bid], [offer])
    m.events.append(Ev(2, 2.0, "auction_awarded", {"auction_id": "scout-1/1"}))
    second = rec.collect()
    assert [e["seq"] for e in second.events] == [2]
    assert not second.new_auctions and len(second.changed_auctions) == 1
    assert [a["outcome"] for a in second.awards] == ["pending"] and not second.bids

    m.auctions[0].d = _auction("closed", [bid], [{**offer, "outcome": "accepted"}])
    third = rec.collect()  # no event named it, but an open auction is watched
    assert third.changed_awards == [
        {"mission_id": 7, "auction_id": "scout-1/1", "idx": 0, "outcome": "accepted"}
    ]
    assert third.changed_auctions[0]["status"] == "closed" and not third.awards
    assert not rec.collect().changed_auctions  # settled: no longer watched


def test_continues_from_what_is_stored() -> None:
    m = FakeMission()
    bid = {"t": 1.5, "bidder": "excavator-1", "utility": -3.0, "round": 0}
    offer = {"t": 2.0, "winner": "excavator-1", "outcome": "accepted"}
    m.auctions.append(Rec("scout-1/1", _auction("closed", [bid], [offer])))
    m.events += [Ev(i, float(i), "message", {}) for i in range(5)]
    rec = Recorder(7, m, Stored(events=3, bids={"scout-1/1": 1}, awards={"scout-1/1": ["pending"]}))
    batch = rec.collect()
    assert [e["seq"] for e in batch.events] == [3, 4]
    assert not batch.bids and not batch.awards and not batch.new_auctions
    assert batch.changed_awards[0]["outcome"] == "accepted"
