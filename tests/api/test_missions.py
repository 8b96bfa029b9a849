"""REST behaviour: creation, validation, lifecycle controls, 404/409/422, the dashboard mount."""

from __future__ import annotations

from pathlib import Path

import httpx
import pytest
from websockets.exceptions import ConnectionClosed

from engine.policies import unused_number
from tests.api.conftest import LiveServer, make_settings, recv, run_to_end

FAST = {"planner": "straight"}  # tests of the REST surface, not of paths: fast planner


def _message(r: httpx.Response) -> str:
    assert r.status_code == 422, r.text
    message: str = r.json()["message"]
    return message


def test_health_and_reference_scenario(api: httpx.Client) -> None:
    assert api.get("/api/health").json()["status"] == "ok"
    ref = api.get("/api/scenarios/reference").json()
    assert ref["sites"] == 10 and ref["minerals"] == 64
    assert ref["team"] == {"scouts": 2, "excavators": 4, "haulers": 6}


def test_create_paused_then_list_filter_and_read(api: httpx.Client) -> None:
    r = api.post("/api/missions", json={"policy": 2, "seed": 7, "speed": 0, **FAST})
    assert r.status_code == 201, r.text
    m = r.json()
    assert m["status"] == "paused" and m["policy"] == "coalition" and m["speed"] == 1.0
    assert m["metrics"]["sites_found"] == 0 and m["actions"] == []
    other = api.post("/api/missions", json={"policy": "nearest", "paused": True, **FAST}).json()
    page = api.get("/api/missions", params={"policy": "coalition"}).json()
    assert [x["id"] for x in page["items"]] == [m["id"]] and page["total"] == 1
    page = api.get("/api/missions", params={"status": "paused", "limit": 1}).json()
    assert page["total"] == 2 and [x["id"] for x in page["items"]] == [other["id"]]
    got = api.get(f"/api/missions/{m['id']}").json()
    assert got["seed"] == 7 and got["scenario"]["name"] == "reference"


def test_unknown_mission_is_404(api: httpx.Client, server: LiveServer) -> None:
    for method, path in [
        ("GET", "/api/missions/999"),
        ("GET", "/api/missions/999/robots"),
        ("GET", "/api/missions/999/auctions"),
        ("GET", "/api/missions/999/events"),
        ("POST", "/api/missions/999/pause"),
        ("POST", "/api/missions/999/stop"),
    ]:
        r = api.request(method, path)
        assert r.status_code == 404, (path, r.text)
        assert "999" in r.json()["detail"]
    with server.ws(999) as ws, pytest.raises(ConnectionClosed) as closed:
        recv(ws)
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 4404


def test_unknown_robot_is_404(api: httpx.Client) -> None:
    mid = api.post("/api/missions", json={"paused": True, **FAST}).json()["id"]
    r = api.post(f"/api/missions/{mid}/robots/hauler-99/disable")
    assert r.status_code == 404 and "hauler-99" in r.json()["detail"]


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"seed": -1}, "body.seed"),
        ({"policy": "bogus"}, "body.policy"),
        ({"speed": "fast"}, "body.speed"),
        ({"speed": 1e9}, "body.speed"),
        ({"planner": "rrt"}, "body.planner"),
        ({"colour": "red"}, "body.colour"),
        ({"scenario": {"team": {"haulers": 0}}}, "body.scenario.team.haulers"),
        ({"scenario": {"width": "NaN"}}, "body.scenario.width"),
        ({"scenario": {"sites": 5000}}, "sites"),
    ],
)
def test_invalid_body_is_422_naming_the_field(api: httpx.Client, body: dict, field: str) -> None:
    assert field in _message(api.post("/api/missions", json=body))


def test_invalid_commands_are_422_naming_the_field(api: httpx.Client) -> None:
    mid = api.post("/api/missions", json={"paused": True, **FAST}).json()["id"]
    base = f"/api/missions/{mid}"
    assert "body.location" in _message(api.post(f"{base}/tasks", json={"location": [500, 5]}))
    assert "body.location" in _message(api.post(f"{base}/tasks", json={"location": [1]}))
    assert "body.type" in _message(
        api.post(f"{base}/tasks", json={"type": "x", "location": [5, 5]})
    )
    assert "body.position" in _message(
        api.post(f"{base}/robots", json={"type": "hauler", "position": [-1, 5]})
    )
    assert "body.type" in _message(api.post(f"{base}/robots", json={"type": "drone"}))
    assert "body.mode" in _message(
        api.post(f"{base}/robots/hauler-1/disable", json={"mode": "gently"})
    )
    assert "body.speed" in _message(api.put(f"{base}/speed", json={"speed": -1}))
    assert "body.policy" in _message(api.put(f"{base}/policy", json={"policy": unused_number()}))
    assert "query.limit" in _message(api.get(f"{base}/events", params={"limit": 10**6}))
    assert "path.mission_id" in _message(api.get("/api/missions/abc"))


def test_lifecycle_controls_and_409_once_finished(api: httpx.Client) -> None:
    m = api.post("/api/missions", json={"paused": True, **FAST}).json()
    base = f"/api/missions/{m['id']}"
    assert api.post(f"{base}/resume").json()["status"] == "running"
    assert api.put(f"{base}/speed", json={"speed": 50}).json()["speed"] == 50
    assert api.put(f"{base}/speed", json={"speed": 0}).json()["status"] == "paused"
    resumed = api.post(f"{base}/resume").json()
    assert resumed["status"] == "running" and resumed["speed"] == 50
    robot = api.post(f"{base}/robots", json={"type": "hauler"})
    assert robot.status_code == 201 and robot.json()["name"] == "hauler-7"
    stopped = api.post(f"{base}/stop").json()
    assert stopped["status"] == "stopped" and stopped["ended_at"] is not None
    for method, path, body in [
        ("POST", f"{base}/pause", None),
        ("POST", f"{base}/resume", None),
        ("POST", f"{base}/stop", None),
        ("PUT", f"{base}/speed", {"speed": 10}),
        ("PUT", f"{base}/policy", {"policy": 3}),
        ("POST", f"{base}/robots", {"type": "scout"}),
        ("POST", f"{base}/robots/scout-1/disable", None),
        ("POST", f"{base}/tasks", {"location": [10, 10]}),
    ]:
        r = api.request(method, path, json=body)
        assert r.status_code == 409, (path, r.text)
        assert "stopped" in r.json()["detail"]
    got = api.get(base).json()
    kinds = [a["kind"] for a in got["actions"]]
    assert kinds == ["resume", "speed", "pause", "resume", "add_robot", "stop"]
    assert got["metrics"]["status"] == "running"  # the engine's view when it was stopped
    robots = api.get(f"{base}/robots").json()
    assert {r["name"] for r in robots} >= {"hauler-7", "scout-1"}


def test_finished_mission_record_is_complete(api: httpx.Client) -> None:
    mid = api.post("/api/missions", json={"seed": 2, "speed": "max"}).json()["id"]
    m = run_to_end(api, mid)
    assert m["status"] == "completed" and m["ended_at"] is not None
    metrics = m["metrics"]
    assert metrics["minerals_delivered"] == 64
    events = api.get(f"/api/missions/{mid}/events", params={"limit": 1}).json()
    assert events["total"] > 1000
    ended = api.get(f"/api/missions/{mid}/events", params={"kind": "mission_ended"}).json()
    assert ended["total"] == 1 and ended["items"][0]["data"]["status"] == "completed"
    window = api.get(
        f"/api/missions/{mid}/events", params={"t_min": 100, "t_max": 200, "limit": 1000}
    ).json()
    assert all(100 <= e["t"] <= 200 for e in window["items"]) and window["total"] > 0
    page1 = api.get(f"/api/missions/{mid}/events", params={"limit": 50}).json()
    page2 = api.get(f"/api/missions/{mid}/events", params={"after": page1["next_after"]}).json()
    assert page2["items"][0]["seq"] == page1["items"][-1]["seq"] + 1
    auctions = api.get(f"/api/missions/{mid}/auctions", params={"limit": 500}).json()
    assert auctions["total"] == metrics["auctions"]
    assert all(a["status"] != "open" for a in auctions["items"])
    closed = [a for a in auctions["items"] if a["status"] == "closed"]
    assert closed and all(a["allocated_to"] and a["closed_at"] >= a["opened_at"] for a in closed)
    assert all(a["bids"] and a["awards"] for a in closed)
    s2e = api.get(f"/api/missions/{mid}/auctions", params={"kind": "scout_excavator"}).json()
    assert s2e["total"] > 0 and {a["kind"] for a in s2e["items"]} == {"scout_excavator"}


def test_dashboard_is_served_and_api_wins(tmp_path: Path) -> None:
    front = tmp_path / "front"
    front.mkdir()
    (front / "index.html").write_text("<!doctype html><title>dash</title>")
    (front / "app.js").write_text("console.log(1)")
    server = LiveServer(make_settings(tmp_path, frontend_dir=front)).start()
    try:
        with server.client(token=False) as anon:
            index = anon.get("/")
            assert index.status_code == 200 and "<title>dash" in index.text
            assert index.headers["x-content-type-options"] == "nosniff"
            assert anon.get("/app.js").text == "console.log(1)"
            assert anon.get("/api/health").json()["status"] == "ok"
            assert anon.get("/api/nothing").status_code == 404
    finally:
        server.stop()


def test_app_starts_without_a_dashboard(tmp_path: Path) -> None:
    server = LiveServer(make_settings(tmp_path, frontend_dir=tmp_path / "missing")).start()
    try:
        with server.client(token=False) as anon:
            assert "/docs" in anon.get("/").text
    finally:
        server.stop()
