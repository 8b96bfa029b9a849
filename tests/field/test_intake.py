"""Mission control's intake of agents' reports (field/intake.py): whatever a member sends,
the intake either refuses it or keeps a record the service can store and stream."""

from __future__ import annotations

import json
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from app.live.recorder import auction_row
from app.live.records import auction_dict
from engine import Mission
from engine.scenario import reference_scenario
from field.intake import Intake
from field.trust import Rejected

JUNK = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=6),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=8,
)


class _Link:  # the intake's `take` needs no link
    pass


def _real_records() -> list[dict[str, Any]]:
    m = Mission(reference_scenario(), 0, "nearest")
    try:
        m.advance(1500)
        return [a.to_dict() for a in m.auctions[:20]]
    finally:
        m.close()


REAL = _real_records()


def _take(data: Any, sender: str = "excavator-1") -> Intake | None:
    rec = Intake(_Link())  # type: ignore[arg-type]
    try:
        rec.take(sender, data)
    except (Rejected, ValidationError, ValueError, TypeError):
        return None
    return rec


def _storable(rec: Intake) -> None:
    for a in rec.auctions.values():
        auction_row(1, a)
        auction_dict(a)
        json.dumps(a, allow_nan=False)
    for e in rec.events:
        json.dumps(e, allow_nan=False)
        assert isinstance(e["t"], float)


@settings(max_examples=300, deadline=None)
@given(data=st.dictionaries(st.sampled_from(["kind", "record", "t", "event", "data", "by"]), JUNK))
def test_junk_is_refused_or_storable(data: dict[str, Any]) -> None:
    rec = _take(data)
    if rec is not None:
        _storable(rec)


@settings(max_examples=300, deadline=None)
@given(i=st.integers(0, len(REAL) - 1), key=st.sampled_from(sorted(REAL[0])), value=JUNK)
def test_a_real_record_with_one_field_spoiled(i: int, key: str, value: Any) -> None:
    record = {**REAL[i], key: value}
    rec = _take({"kind": "auction", "record": record}, record.get("auctioneer") or "x")
    if rec is not None:
        _storable(rec)


def test_a_record_of_another_auctioneer_is_refused_and_a_real_one_kept() -> None:
    real = next(r for r in REAL if r["auctioneer"].startswith("scout"))
    with pytest.raises(Rejected):
        Intake(_Link()).take("hauler-1", {"kind": "auction", "record": real})  # type: ignore[arg-type]
    rec = _take({"kind": "auction", "record": real}, real["auctioneer"])
    assert rec is not None and list(rec.auctions) == [real["id"]]
    for bad in ({"id": "forged/1"}, {**real, "awards": [{}]}, {**real, "opened_at": "abc"}):
        assert _take({"kind": "auction", "record": bad}, real["auctioneer"]) is None
    assert _take({"kind": "event", "t": "abc", "event": "x", "data": {}, "by": "x"}, "x") is None
    assert _take({"kind": "event", "t": 1.0, "event": "dug", "data": {}, "by": "y"}, "x") is None
    nan = {"kind": "event", "t": 1.0, "event": "dug", "data": {"a": [float("nan")]}, "by": "x"}
    assert _take(nan, "x") is None
