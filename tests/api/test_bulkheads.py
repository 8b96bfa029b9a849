"""Bulkheads: nothing one live mission produces can stop the service for another.

A live mission whose own data is hostile (random, malformed, not-JSON records and events, a
frame that cannot be sent: what a field mission would pass on if a forgery got past its
checks) is put in the runner of a real server beside a simulated mission with a viewer. Each
time, the hostile mission alone ends `failed` with the reason stored; the other mission's
frames and stored events go on; the server's health answers; shutdown still writes
everything the other mission produced.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.live.recorder import Recorder
from app.live.streaming import note_event
from engine import Event
from tests.api.conftest import LiveServer, make_settings, recv_until, wait_for

JUNK = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**70), max_value=2**70)
    | st.floats()
    | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=6,
)
AUCTION_KEYS = [
    "id",
    "kind",
    "auctioneer",
    "task_type",
    "location",
    "status",
    "opened_at",
    "awards",
    "bids",
    "closed_at",
    "policy",
    "task_id",
    "reannouncements",
]
RECORD = st.dictionaries(st.sampled_from(AUCTION_KEYS) | st.text(max_size=5), JUNK, max_size=10)
EVENT = st.tuples(JUNK, JUNK, st.dictionaries(st.sampled_from(["auction_id", "robot"]), JUNK))
HOSTILE = st.fixed_dictionaries(
    {
        "records": st.lists(RECORD, max_size=4),
        "events": st.lists(EVENT, max_size=6),
        "frame": st.sampled_from(["raises", "not json", "junk"]),
        "frame_junk": JUNK,
    }
)


class _View:
    def __init__(self, d: dict[str, Any]) -> None:
        self.d = d
        self.id = d.get("id")

    def to_dict(self) -> dict[str, Any]:
        return self.d


class HostileMission:
    """The surface the runner and the services read, over hostile data."""

    mode = "simulated"

    def __init__(self, plan: dict[str, Any], snapshot: dict[str, Any]) -> None:
        self.plan, self._snapshot = plan, snapshot
        self.now, self.done, self.status = 0.0, False, "running"
        self.policy = self.initial_policy = "fcfs"
        self.actions: list[dict[str, Any]] = []
        self.events: list[Event] = []
        self.auctions: list[_View] = []
        self._subs: list[Any] = []
        self.closed = False

    def subscribe(self, fn: Any) -> None:
        self._subs.append(fn)

    def advance(self, until: float) -> None:
        self.now = min(until, self.now + 1.0)
        if self.events:
            return
        self.auctions.extend(_View(r) for r in self.plan["records"])
        for i, (t, kind, data) in enumerate(self.plan["events"]):
            data = dict(data)
            if self.plan["records"] and i == 0:
                data["auction_id"] = self.plan["records"][0].get("id")
            ev = Event(i, t, kind, data)  # type: ignore[arg-type]
            self.events.append(ev)
            for fn in self._subs:
                fn(ev)

    def frame(self) -> dict[str, Any]:
        how = self.plan["frame"]
        if how == "raises":
            raise KeyError("status")
        if how == "not json":
            return {"t": math.nan, "robots": {object()}}
        return {"t": self.now, "junk": self.plan["frame_junk"]}

    def snapshot(self) -> dict[str, Any]:
        return self._snapshot

    def metrics(self) -> dict[str, Any]:
        return {"awards": [{}], "t": self.plan["frame_junk"]}

    def robot_list(self) -> list[dict[str, Any]]:
        return []

    def world_map(self) -> dict[str, Any]:
        return {"width": 100, "height": 100}

    def close(self) -> None:
        self.closed = True


def _events(api: Any, mid: int) -> int:
    return int(api.get(f"/api/missions/{mid}/events", params={"limit": 1}).json()["total"])


@pytest.fixture(scope="module")
def server(backend: str, tmp_path_factory: pytest.TempPathFactory) -> Any:
    live = LiveServer(make_settings(tmp_path_factory.mktemp("bulkheads"), frame_hz=20)).start()
    yield live
    live.stop()


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(plan=HOSTILE)
def test_a_hostile_mission_ends_alone(server: LiveServer, plan: dict[str, Any]) -> None:
    runner = server._server.config.app.state.services.runner  # type: ignore[union-attr]
    with server.client() as api, server.ws(_ensure_other(api)) as ws:
        other = _ensure_other(api)
        recv_until(ws, lambda m: m["type"] == "frame", [])
        before = _events(api, other)
        mid = api.post("/api/missions", json={"seed": 3, "speed": 0}).json()["id"]
        lm = runner.live[mid]
        with runner.gate:
            snap = lm.mission.snapshot()
            lm.mission.close()
            lm.mission = HostileMission(plan, snap)
            lm.recorder = Recorder(mid, lm.mission)
            lm.mission.subscribe(lambda ev: note_event(lm, ev))
            lm.paused, lm.speed = False, None
        runner.stepper.wake()
        with server.ws(mid):  # a viewer: the frame path runs for it too
            row = wait_for(
                lambda: (r := api.get(f"/api/missions/{mid}").json())["status"] != "running" and r
            )
        assert row["status"] == "failed" and row["error"], row
        assert lm.mission.closed
        assert api.get("/api/health").status_code == 200
        # the other mission goes on: new frames, new stored events
        recv_until(ws, lambda m: m["type"] == "frame", [])
        wait_for(lambda: _events(api, other) > before)


_OTHER: dict[str, int] = {}  # server -> its other mission


def _ensure_other(api: Any) -> int:
    """One simulated mission beside every hostile one (one per server: each database), at a
    pace that lasts the test."""
    key = str(api.base_url)
    if key not in _OTHER or api.get(f"/api/missions/{_OTHER[key]}").json()["status"] != "running":
        _OTHER[key] = api.post("/api/missions", json={"seed": 5, "speed": 2}).json()["id"]
    return _OTHER[key]


def test_shutdown_flushes_the_other_mission_after_a_hostile_one(tmp_path: Path) -> None:
    live = LiveServer(make_settings(tmp_path, frame_hz=20)).start()
    runner = live._server.config.app.state.services.runner  # type: ignore[union-attr]
    with live.client() as api:
        other = api.post("/api/missions", json={"seed": 5, "speed": 50}).json()["id"]
        mid = api.post("/api/missions", json={"seed": 3, "speed": 0}).json()["id"]
        plan = {
            "records": [{"id": "forged/1"}],
            "events": [(0.0, "x", {})],
            "frame": "raises",
            "frame_junk": None,
        }
        lm = runner.live[mid]
        with runner.gate:
            lm.mission = HostileMission(plan, lm.mission.snapshot())
            lm.recorder = Recorder(mid, lm.mission)
            lm.paused, lm.speed = False, None
        runner.stepper.wake()
        wait_for(lambda: api.get(f"/api/missions/{mid}").json()["status"] == "failed")
        wait_for(lambda: api.get(f"/api/missions/{other}").json()["sim_time"] > 100)
        t_before = api.get(f"/api/missions/{other}").json()["sim_time"]
    live.stop()
    live.start()
    try:
        with live.client() as api:
            row = api.get(f"/api/missions/{other}").json()
            assert row["status"] == "interrupted" and row["sim_time"] >= t_before
            assert _events(api, other) > 0
            failed = api.get(f"/api/missions/{mid}").json()
            assert failed["status"] == "failed" and "KeyError" in failed["error"]
    finally:
        live.stop()
