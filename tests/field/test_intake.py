"""Mission control's intake of agents' reports (field/intake.py): whatever a member sends,
the intake either refuses it or keeps a record the service can store and stream."""

from __future__ import annotations

import itertools
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
from engine.team import robot_type
from field.intake import Intake
from field.link import Link
from field.trust import Authority, Rejected, Sealer
from field.wire import encode_json, event_key

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


# --- poses --------------------------------------------------------------------------------

POSE = {"kind": "pose", "t": 12.5, "x": 40.0, "y": 61.25, "heading": -1.5, "state": "carrying"}
HOSTILE_POSES: list[tuple[str, dict[str, Any]]] = [
    ("NaN", {**POSE, "x": float("nan")}),
    ("infinity", {**POSE, "heading": float("inf")}),
    ("huge x", {**POSE, "x": 1e300}),
    ("huge y", {**POSE, "y": -2e6}),
    ("negative t", {**POSE, "t": -1.0}),
    ("NaN t", {**POSE, "t": float("nan")}),
    ("text x", {**POSE, "x": "40"}),
    ("bool load", {**POSE, "load": True}),
    ("float load", {**POSE, "load": 1.5}),
    ("huge load", {**POSE, "load": 10**9}),
    ("negative load", {**POSE, "load": -1}),
    ("long state", {**POSE, "state": "x" * 200}),
    ("odd state", {**POSE, "state": "<script>"}),
    ("list state", {**POSE, "state": ["idle"]}),
    ("missing y", {k: v for k, v in POSE.items() if k != "y"}),
    ("extra field", {**POSE, "robot": "hauler-1"}),
    ("another robot", {**POSE, "by": "hauler-2"}),
]


class _Sample:
    def __init__(self, key: str, payload: bytes) -> None:
        self.key_expr, self._payload = key, payload

    @property
    def payload(self) -> _Sample:
        return self

    def to_bytes(self) -> bytes:
        return self._payload


def _signed_intake() -> tuple[Intake, dict[str, Sealer]]:
    """Mission control's intake behind a real link, and sealers of its robots."""
    authority = Authority("m1")
    intake = Intake(Link(None, authority.control, "mission control"))  # type: ignore[arg-type]
    who = {n: Sealer(authority.issue(n, robot_type(n))) for n in ("hauler-1", "operator")}
    return intake, who


_NUMBERS: dict[Sealer, itertools.count[int]] = {}


def _send(intake: Intake, sealer: Sealer, data: dict[str, Any]) -> None:
    """As an agent reports: numbered in its life (`field.journal`), signed, put."""
    key = event_key("m1", sealer.name)
    data = {**data, "rseq": next(_NUMBERS.setdefault(sealer, itertools.count()))}
    intake.on_report(_Sample(key, sealer.seal(key, encode_json(data))))


def test_a_robots_pose_is_kept_in_its_own_name() -> None:
    intake, who = _signed_intake()
    _send(intake, who["hauler-1"], {**POSE, "load": 1})
    _send(intake, who["hauler-1"], {**POSE, "t": 17.5, "by": "hauler-1", "load": 0})
    life = {"source": "hauler-1#1"}
    assert intake.poses == [
        {"robot": "hauler-1", **{k: v for k, v in POSE.items() if k != "kind"}, "load": 1}
        | life
        | {"rseq": 0},
        {"robot": "hauler-1", **{k: v for k, v in POSE.items() if k != "kind"}, "t": 17.5}
        | {"load": 0}
        | life
        | {"rseq": 1},
    ]
    assert intake.malformed == 0


@pytest.mark.parametrize(("what", "data"), HOSTILE_POSES, ids=[w for w, _ in HOSTILE_POSES])
def test_a_hostile_pose_is_refused_and_counted(what: str, data: dict[str, Any]) -> None:
    intake, who = _signed_intake()
    # (NaN and infinity go out as Python's json writes them, `NaN`: not JSON, refused as
    # malformed before the model sees them)
    _send(intake, who["hauler-1"], {"load": 0, **data})
    assert intake.poses == []
    reasons = intake.rejections()["by_reason"]
    assert sum(reasons.values()) == 1, (what, reasons)
    assert set(reasons) <= {"invalid report", "impersonation", "malformed"}, reasons
    if what == "another robot":
        assert reasons == {"impersonation": 1}


def test_the_operators_console_has_no_pose() -> None:
    intake, who = _signed_intake()
    _send(intake, who["operator"], {**POSE, "load": 0})
    assert intake.poses == []
    assert intake.rejections()["by_reason"] == {"not allowed": 1}


@settings(max_examples=300, deadline=None)
@given(key=st.sampled_from([*POSE, "load", "by"]), value=JUNK)
def test_a_pose_with_one_field_spoiled_is_refused_or_storable(key: str, value: Any) -> None:
    rec = _take({**POSE, "load": 0, key: value}, "hauler-1")
    for p in rec.poses if rec is not None else ():
        json.dumps(p, allow_nan=False)
        assert p["robot"] == "hauler-1" and abs(p["x"]) <= 1e6 and abs(p["y"]) <= 1e6
        assert type(p["load"]) is int and 0 <= p["load"] <= 64 and p["t"] >= 0
