"""Playback: `GET /api/missions/{id}/state?t=` is the mission exactly as it was at `t`.

Checked against what the server stored while the mission ran (events, auctions, the final
state) and against a replay in this process; scrubbed in a random order, so the cursor pool's
reuse (forward from a parked engine, a fresh one for a step back) never changes an answer.
"""

from __future__ import annotations

import json
import random
from bisect import bisect_right
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx

from app.live.records import stream_state
from app.services.cursors import evictions, gap_to_fill, pick
from engine import Mission, reference_scenario
from tests.api.conftest import LiveServer, make_settings, run_to_end, wait_for


def _as_listed(robots: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """A state's robots in the robot list's shape: the list always has `charge` (null with
    energy off); a state has it only with energy on."""
    return [{"charge": None, **r} for r in robots]


def _state(api: httpx.Client, mid: int, t: float) -> dict[str, Any]:
    r = api.get(f"/api/missions/{mid}/state", params={"t": t})
    assert r.status_code == 200, r.text
    body: dict[str, Any] = r.json()
    return body


def _events(api: httpx.Client, mid: int, *kinds: str) -> list[dict[str, Any]]:
    items: list[dict[str, Any]] = []
    after = -1
    while True:
        params: dict[str, Any] = {"kind": list(kinds), "after": after, "limit": 1000}
        page = api.get(f"/api/missions/{mid}/events", params=params).json()
        items += page["items"]
        if page["next_after"] is None:
            return items
        after = page["next_after"]


def _check_against_log(body: dict[str, Any], log: dict[str, list[dict[str, Any]]]) -> None:
    """Counters, sites, robots and deliveries at `t` agree with the stored events up to `t`."""
    t, state = body["t"], body["state"]
    assert state["t"] == t
    found = [e for e in log["site_found"] if e["t"] <= t]
    assert state["counters"]["sites_found"] == len(found)
    assert {s["id"] for s in state["sites"] if s["found"]} == {e["data"]["site"] for e in found}
    delivered = [e for e in log["delivered"] if e["t"] <= t]
    assert state["counters"]["minerals_delivered"] == (
        delivered[-1]["data"]["delivered"] if delivered else 0
    )
    assert body["deliveries"] == delivered
    failed = {e["data"]["robot"] for e in log["robot_failed"] if e["t"] <= t}
    added = {e["data"]["robot"] for e in log["robot_added"] if e["t"] > t}
    robots = {r["name"]: r for r in state["robots"]}
    assert failed <= {n for n, r in robots.items() if r["state"] == "failed"}
    assert not added & robots.keys()
    switches = [e for e in log["policy_changed"] if e["t"] <= t]
    if switches:
        assert state["policy"] == switches[-1]["data"]["new"]
    for a in body["auctions"]:
        assert a["opened_at"] <= t and all(b["t"] <= t for b in a["bids"])
        assert a["status"] == "open" or a["closed_at"] <= t
    assert {a["id"] for a in state["auctions"]} == {
        a["id"] for a in body["auctions"] if a["status"] == "open"
    }


def test_scrub_a_finished_mission_with_operator_actions(server: LiveServer) -> None:
    with server.client() as api:
        mid = api.post("/api/missions", json={"seed": 3, "speed": 300}).json()["id"]
        base = f"/api/missions/{mid}"
        wait_for(lambda: api.get(base).json()["sim_time"] > 150)
        api.post(f"{base}/robots/hauler-1/disable", json={"mode": "abrupt"}).raise_for_status()
        api.post(f"{base}/robots", json={"type": "hauler"}).raise_for_status()
        wait_for(lambda: api.get(base).json()["sim_time"] > 400)
        api.put(f"{base}/policy", json={"policy": "coalition"}).raise_for_status()
        record = run_to_end(api, mid)
        end = record["sim_time"]
        assert record["status"] == "completed"

        kinds = ("site_found", "delivered", "robot_failed", "robot_added", "policy_changed")
        stored = _events(api, mid, *kinds)
        log = {k: [e for e in stored if e["kind"] == k] for k in kinds}
        assert log["robot_failed"] and log["robot_added"] and log["policy_changed"]
        every_t = [e["t"] for e in _events(api, mid)]
        marks = [e["t"] for e in stored]
        rng = random.Random(13)
        times = [0.0, end, *rng.sample(marks, 6), *(rng.uniform(0, end) for _ in range(6))]
        answers: dict[float, dict[str, Any]] = {}
        for t in sorted(times):
            body = answers[t] = _state(api, mid, t)
            assert body["end"] == end and body["mission"]["status"] == "completed"
            assert body["events"] == bisect_right(every_t, t)  # every event up to t, no later
            _check_against_log(body, log)
        rng.shuffle(times)  # back and forth: parked engines and fresh ones answer alike
        for t in times:
            assert _state(api, mid, t) == answers[t]

        # the last moment is the state the server stored when the mission ended
        final = api.get(f"{base}/robots").json()
        assert _as_listed(answers[end]["state"]["robots"]) == final
        # and any moment is what an engine of our own shows after the same actions
        actions = [a for a in api.get(f"{base}/actions").json() if a["replay"]]
        t = sorted(times)[len(times) // 2]
        m = Mission(reference_scenario(), 3, "fcfs")
        try:
            for a in actions:
                if a["t"] <= t:
                    m.apply(a)
            m.advance(t)
            assert answers[t]["state"] == json.loads(json.dumps(stream_state(m.snapshot())))
        finally:
            m.close()

        for params, field in [({"t": end + 1}, "query.t"), ({"t": -1}, "query.t"), ({}, "query.t")]:
            r = api.get(f"{base}/state", params=params)
            assert r.status_code == 422 and r.json()["message"].startswith(field), r.text
        assert api.get(f"{base}/state", params={"t": "nan"}).status_code == 422
        assert api.get("/api/missions/9999/state", params={"t": 1}).status_code == 404


def test_scrub_live_then_interrupted(tmp_path: Path) -> None:
    """Two viewers scrub a running mission at once; its answers stand once it is interrupted
    by a restart (and the last stored time shows the state the server stored then)."""
    server = LiveServer(make_settings(tmp_path)).start()
    try:
        with server.client() as api:
            body = {"seed": 8, "speed": 150, "planner": "exact"}  # replayed with its own planner
            mid = api.post("/api/missions", json=body).json()["id"]
            base = f"/api/missions/{mid}"
            wait_for(lambda: api.get(base).json()["sim_time"] > 100)
            api.put(f"{base}/policy", json={"policy": "nearest"}).raise_for_status()
            api.post(f"{base}/robots/excavator-2/disable", json={"mode": "abrupt"})
            now = wait_for(lambda: (s := api.get(base).json()["sim_time"]) > 250 and s)
            times = [10.0, 99.0, now * 0.7, now]
            with ThreadPoolExecutor(4) as pool:  # viewers at different times, concurrently
                live = dict(zip(times, pool.map(lambda t: _state(api, mid, t), times), strict=True))
            ahead = api.get(f"{base}/state", params={"t": now + 10_000})
            assert ahead.status_code == 422 and ahead.json()["message"].startswith("query.t")
            api.post(f"{base}/pause").raise_for_status()
            paused_at = api.get(base).json()["sim_time"]

        server.restart()

        with server.client() as api:
            assert api.get(base).json()["status"] == "interrupted"
            kinds = ("site_found", "delivered", "robot_failed", "robot_added", "policy_changed")
            stored = _events(api, mid, *kinds)
            log = {k: [e for e in stored if e["kind"] == k] for k in kinds}
            for t, body in live.items():
                again = _state(api, mid, t)
                assert again["state"] == body["state"] and again["auctions"] == body["auctions"]
                _check_against_log(again, log)
            last = _state(api, mid, paused_at)
            assert _as_listed(last["state"]["robots"]) == api.get(f"{base}/robots").json()
            assert api.get(f"{base}/state", params={"t": paused_at + 1}).status_code == 422
    finally:
        server.stop()


def test_scrub_a_stalled_mission(server: LiveServer) -> None:
    """Both scouts fail early: nothing more is found, and the mission ends `stalled`."""
    scenario = {**reference_scenario().model_dump(mode="json"), "stall_timeout_s": 100.0}
    with server.client() as api:
        body = {"seed": 1, "speed": 20, "scenario": scenario, "planner": "straight"}
        mid = api.post("/api/missions", json=body).json()["id"]
        base = f"/api/missions/{mid}"
        wait_for(lambda: api.get(base).json()["sim_time"] > 5)
        for scout in ("scout-1", "scout-2"):
            api.post(f"{base}/robots/{scout}/disable", json={"mode": "abrupt"}).raise_for_status()
        record = run_to_end(api, mid)
        assert record["status"] == "stalled"
        failed_at = next(a["t"] for a in api.get(f"{base}/actions").json() if a["replay"])
        before = _state(api, mid, failed_at / 2)["state"]
        assert {r["state"] for r in before["robots"] if r["type"] == "scout"} != {"failed"}
        last = _state(api, mid, record["sim_time"])
        assert last["mission"]["status"] == "stalled"
        assert _as_listed(last["state"]["robots"]) == api.get(f"{base}/robots").json()
        assert {r["state"] for r in last["state"]["robots"] if r["type"] == "scout"} == {"failed"}
        assert api.get(f"{base}/state", params={"t": record["sim_time"] + 1}).status_code == 422


@dataclass
class _Slot:
    mission_id: int
    at: float
    used: int


def test_pool_rules() -> None:
    a, b, c = _Slot(1, 10.0, 1), _Slot(1, 50.0, 2), _Slot(2, 5.0, 3)
    assert pick([a, b, c], 1, 49.0) is a and pick([a, b, c], 1, 50.0) is b
    assert pick([a, b, c], 1, 9.0) is None and pick([a, b, c], 3, 100.0) is None
    # per mission: the playhead (newest) stays, the most crowded of the others goes
    crowd = [_Slot(1, 10.0, 5), _Slot(1, 12.0, 1), _Slot(1, 60.0, 2), _Slot(1, 11.0, 9)]
    assert evictions(crowd, 3, 100) == [crowd[1]]
    # across missions: the least recently used go
    assert evictions([a, b, c], 10, 2) == [a]
    assert gap_to_fill([], 100.0, 5) == 50.0
    assert gap_to_fill([50.0], 100.0, 5) == 25.0  # of equal stretches the earlier
    assert gap_to_fill([20.0, 45.0, 70.0], 100.0, 5) == 85.0
    assert gap_to_fill([25.0, 50.0, 75.0], 100.0, 5) is None  # every stretch <= 100 / 4
    assert gap_to_fill([10.0, 20.0, 30.0, 40.0, 50.0], 100.0, 5) is None  # no room
