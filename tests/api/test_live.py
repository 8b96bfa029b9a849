"""The live stream against a real server: snapshot, frames, auctions, events, status."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import httpx
import pytest
import websockets

from bench.slow_viewer import gauge, stalled_viewer
from tests import aio
from tests.api.conftest import LiveServer, all_pages, recv, recv_until
from tests.api.serve_process import ServeProcess
from tests.progress import Progress

Msg = dict[str, Any]
LONG = {"minerals": 1500, "max_time_s": 10_000_000}  # outlasts any test window


def _create(api: httpx.Client, **body: Any) -> int:
    r = api.post("/api/missions", json={"paused": True, **body})
    assert r.status_code == 201, r.text
    mission_id: int = r.json()["id"]
    return mission_id


def _of(seen: list[Msg], kind: str) -> list[Msg]:
    return [m for m in seen if m["type"] == kind]


def _ended(m: Msg) -> bool:
    return m["type"] == "status" and m["status"] not in ("running", "paused")


def test_snapshot_frames_and_events_until_the_mission_finishes(
    server: LiveServer, api: httpx.Client
) -> None:
    mid = _create(api, seed=1, speed=1500)
    with server.ws(mid) as ws:
        snap = recv(ws)
        assert snap["type"] == "snapshot" and snap["mission"]["id"] == mid
        assert snap["mission"]["status"] == "paused"
        assert snap["map"]["plant"] == {"x": 50.0, "y": 50.0} and len(snap["map"]["sites"]) == 10
        assert len(snap["state"]["robots"]) == 12 and snap["state"]["t"] == 0
        api.post(f"/api/missions/{mid}/resume").raise_for_status()
        seen: list[Msg] = []
        final = recv_until(ws, _ended, seen)
    assert final["status"] == "completed" and final["policy"] == "fcfs"
    assert _of(seen, "status")[0]["status"] == "running"
    frames = _of(seen, "frame")
    assert len(frames) >= 10
    times = [f["t"] for f in frames]
    assert times == sorted(times) and frames[-1]["status"] == "completed"
    assert {"name", "state", "x", "y", "load"} <= set(frames[0]["robots"][0])
    kinds = {m["event"]["kind"] for m in _of(seen, "event")}
    assert {"site_found", "auction_opened", "delivered", "mission_ended"} <= kinds
    assert "message" not in kinds
    seqs = [m["event"]["seq"] for m in _of(seen, "event")]
    assert seqs == sorted(seqs)
    streamed = {m["auction"]["id"]: m["auction"] for m in _of(seen, "auction")}
    stored = all_pages(api, f"/api/missions/{mid}/auctions")
    assert set(streamed) == {a["id"] for a in stored}
    for a in stored:  # the last streamed state of each auction is what was stored
        last = streamed[a["id"]]
        assert (last["status"], last["allocated_to"]) == (a["status"], a["allocated_to"])
        assert len(last["bids"]) == len(a["bids"])
        assert set(last) == set(a)  # one shape: the stream's auction is an AuctionRead
        assert last["declines"] == a["declines"]
    record = api.get(f"/api/missions/{mid}").json()
    assert record["status"] == "completed" and record["metrics"]["minerals_delivered"] == 64


def test_finished_mission_snapshot_comes_from_the_record(
    server: LiveServer, api: httpx.Client
) -> None:
    mid = _create(api, seed=3, speed="max", planner="straight")  # speed, not paths, matters
    api.post(f"/api/missions/{mid}/resume")
    with server.ws(mid) as ws:
        recv_until(ws, lambda m: m["type"] == "snapshot", [])
        recv_until(ws, _ended, [])
    with server.ws(mid) as ws:
        snap = recv(ws)
    assert snap["mission"]["status"] == "completed"
    assert snap["state"]["status"] == "completed" and snap["map"]["width"] == 100


@pytest.mark.parametrize(
    ("mode", "event", "state"),
    [("abrupt", "robot_failed", "failed"), ("graceful", "robot_disabled", "disabled")],
)
def test_disabled_robot_shows_in_the_stream_and_its_auctions(
    server: LiveServer, api: httpx.Client, mode: str, event: str, state: str
) -> None:
    mid = _create(api, seed=4, speed=400)
    base = f"/api/missions/{mid}"

    def digging(m: Msg) -> bool:
        return m["type"] == "frame" and any(
            r["state"] == "digging" and r["name"].startswith("excavator") for r in m["robots"]
        )

    with server.ws(mid) as ws:
        recv(ws)
        api.post(f"{base}/resume").raise_for_status()
        seen: list[Msg] = []
        frame = recv_until(ws, digging, seen)
        name = next(r["name"] for r in frame["robots"] if r["state"] == "digging")
        r = api.post(f"{base}/robots/{name}/disable", json={"mode": mode})
        assert r.status_code == 200, r.text
        t_off = api.get(f"{base}/actions").json()[-1]["t"]
        recv_until(
            ws,
            lambda m: (
                m["type"] == "event"
                and m["event"]["kind"] == event
                and m["event"]["data"]["robot"] == name
            ),
            seen,
        )
        api.put(f"{base}/speed", json={"speed": 2000}).raise_for_status()
        recv_until(ws, _ended, seen)
    states = [r["state"] for f in _of(seen, "frame") for r in f["robots"] if r["name"] == name]
    assert states[-1] == state
    reauctions = [m["auction"] for m in _of(seen, "auction") if m["auction"]["reauction_of"]]
    assert reauctions, "the failed excavator's site was auctioned again"
    assert api.post(f"{base}/robots/{name}/enable").status_code == 409  # mission is over
    auctions = all_pages(api, f"{base}/auctions", robot=name)
    won = {a["id"] for a in auctions if a["allocated_to"] == name}
    late = [a for a in auctions if a["opened_at"] > t_off]  # it may still hand work over
    assert won and all(a["allocated_to"] != name for a in late)
    assert all(b["utility"] is None for a in late for b in a["bids"] if b["bidder"] == name)
    again = [a for a in all_pages(api, f"{base}/auctions") if a["reauction_of"] in won]
    assert again and all(a["allocated_to"] not in (None, name) for a in again)
    robots = {r["name"]: r for r in api.get(f"{base}/robots").json()}
    assert robots[name]["state"] == state
    record = api.get(base).json()
    assert record["status"] == "completed" and record["metrics"]["minerals_delivered"] == 64
    assert [a["kind"] for a in record["actions"] if a["replay"]] == ["disable_robot"]


def test_injected_task_runs_an_operator_auction(server: LiveServer, api: httpx.Client) -> None:
    mid = _create(api, seed=5, speed=300)
    base = f"/api/missions/{mid}"
    with server.ws(mid) as ws:
        snap = recv(ws)
        site = max(snap["map"]["sites"], key=lambda s: abs(s["x"] - 50) + abs(s["y"] - 50))
        api.post(f"{base}/resume").raise_for_status()
        r = api.post(f"{base}/tasks", json={"type": "excavate", "location": [site["x"], site["y"]]})
        assert r.status_code == 201, r.text
        auction_id = r.json()["auction_id"]
        seen: list[Msg] = []
        first = recv_until(
            ws, lambda m: m["type"] == "auction" and m["auction"]["id"] == auction_id, seen
        )
        assert first["auction"]["kind"] == "operator"
        recv_until(
            ws,
            lambda m: (
                m["type"] == "auction"
                and m["auction"]["id"] == auction_id
                and m["auction"]["status"] == "closed"
            ),
            seen,
        )
    stored = api.get(f"{base}/auctions", params={"kind": "operator"}).json()
    assert stored["total"] == 1
    auction = stored["items"][0]
    assert auction["id"] == auction_id and auction["status"] == "closed"
    assert auction["allocated_to"].startswith("excavator-") and auction["bids"]
    injected = api.get(f"{base}/events", params={"kind": "task_injected"}).json()["items"]
    assert injected[0]["data"]["auction_id"] == auction_id
    api.post(f"{base}/stop").raise_for_status()


def test_policy_change_mid_mission_is_recorded(server: LiveServer, api: httpx.Client) -> None:
    mid = _create(api, seed=6, speed=800, policy="fcfs")
    base = f"/api/missions/{mid}"
    with server.ws(mid) as ws:
        recv(ws)
        api.post(f"{base}/resume").raise_for_status()
        seen: list[Msg] = []
        recv_until(ws, lambda m: m["type"] == "frame" and m["t"] > 500, seen)
        r = api.put(f"{base}/policy", json={"policy": 3})
        assert r.status_code == 200 and r.json()["policy"] == "nearest", r.text
        status = recv_until(ws, lambda m: m["type"] == "status", seen)
        assert status["policy"] == "nearest"
        changed = [m for m in _of(seen, "event") if m["event"]["kind"] == "policy_changed"]
        assert changed[-1]["event"]["data"] == {"old": "fcfs", "new": "nearest"}
        api.put(f"{base}/speed", json={"speed": "max"})
        recv_until(ws, _ended, seen)
    record = api.get(base).json()
    change = [a for a in record["actions"] if a["kind"] == "set_policy"]
    assert len(change) == 1 and change[0]["args"] == {"policy": "nearest"} and change[0]["t"] > 500
    assert record["policy"] == "nearest" and record["initial_policy"] == "fcfs"
    assert record["metrics"]["policy_changes"] == 1
    auctions = all_pages(api, f"{base}/auctions")
    assert {a["policy"] for a in auctions if a["opened_at"] > change[0]["t"]} == {"nearest"}
    assert {a["policy"] for a in auctions if a["opened_at"] < change[0]["t"]} == {"fcfs"}
    listed = api.get("/api/missions", params={"policy": "nearest"}).json()
    assert [m["id"] for m in listed["items"]] == [mid]


SLOW_READERS, SLOW_HZ = 3, 20
_FRAME = '{"type":"frame",'  # frames are recognised without parsing every event


async def _stall_session(port: int, api: httpx.Client, mid: int) -> dict[str, Any]:
    """Readers watch `mid` while a viewer that never reads joins: its sends block and its
    queue grows while the readers keep receiving frames; at "max" its queue fills and the
    server drops it, and the readers carry on. Every step waits for a condition."""
    url = f"ws://127.0.0.1:{port}/api/missions/{mid}/live"
    frames = [0] * SLOW_READERS
    out: dict[str, Any] = {}

    async def read(ws: websockets.ClientConnection, reader: int) -> None:
        async for raw in ws:
            if isinstance(raw, str) and raw.startswith(_FRAME):
                frames[reader] += 1

    async def call(method: str, path: str, **kw: Any) -> httpx.Response:
        r = await asyncio.to_thread(api.request, method, path, **kw)
        r.raise_for_status()
        return r

    async def gauges() -> tuple[int, int]:
        text = (await call("GET", "/api/metrics")).text
        return gauge(text, "regolith_viewers", mid), gauge(text, "regolith_viewer_backlog", mid)

    async def until(what: str, done: Callable[[], Awaitable[bool]]) -> None:
        watch = Progress(what)  # the readers' frames are the server's progress
        while not await done():
            watch.check(sum(frames))
            await asyncio.sleep(0.05)

    async def more_frames(n: int) -> None:
        """Every reader receives `n` more frames."""
        floor = min(frames) + n

        async def done() -> bool:
            return min(frames) >= floor

        await until(f"{n} more frames for every reader", done)

    async def attached_and_queueing() -> bool:
        viewers, backlog = await gauges()
        return viewers == SLOW_READERS + 1 and backlog > 50

    sockets = [await websockets.connect(url, max_size=2**24) for _ in range(SLOW_READERS)]
    for ws in sockets:
        assert json.loads(await ws.recv())["type"] == "snapshot"
    tasks = [asyncio.create_task(read(ws, i)) for i, ws in enumerate(sockets)]
    await call("POST", f"/api/missions/{mid}/resume")
    await more_frames(5)
    stall = await asyncio.to_thread(stalled_viewer, port, mid)
    await until("the stalled viewer's sends block and its queue grows", attached_and_queueing)
    await more_frames(2 * SLOW_HZ)  # two seconds' worth while it is stuck
    out["attached"] = await gauges()  # still there, still not served
    await call("PUT", f"/api/missions/{mid}/speed", json={"speed": "max"})

    async def dropped() -> bool:
        return (await gauges())[0] == SLOW_READERS

    await until("the stalled viewer is dropped once its queue is full", dropped)
    await more_frames(5)  # the others carry on
    out["metrics"] = (await call("GET", "/api/metrics")).text
    stall.close()
    # close while the readers keep draining: a client that stops reading (its own queue
    # full) would not see the server's close frame until its close timeout
    await asyncio.gather(*(ws.close() for ws in sockets))
    await asyncio.gather(*tasks)
    return out


@pytest.mark.sqlite_only  # the fan-out, whatever the database
def test_a_stalled_viewer_queues_then_is_dropped_and_others_keep_their_frames(
    tmp_path: Path,
) -> None:
    """The slow client, the behaviour: a viewer that never reads (a raw socket that stops after the
    handshake) does not hold up the others. Its sends block, its queue grows while the
    readers keep receiving frames, and once the queue is full the server drops it.

    How much it costs the others in frame delay and pace is measured, not asserted here:
    bench/service_bench.py --stalled compares it with a control run (docs/benchmarks.md).
    The server runs in its own process, as `regolith serve`."""
    body = {"seed": 8, "speed": 300, "paused": True, "scenario": LONG, "planner": "straight"}
    env = {"REGOLITH_FRAME_HZ": str(SLOW_HZ), "REGOLITH_VIEWER_QUEUE": "4000"}
    with ServeProcess(tmp_path, "--log-level", "warning", **env) as srv, srv.client() as api:
        mid = api.post("/api/missions", json=body).json()["id"]
        out = aio.run(_stall_session(srv.port, api, mid))
        api.post(f"/api/missions/{mid}/stop").raise_for_status()
    viewers, backlog = out["attached"]
    assert viewers == SLOW_READERS + 1 and backlog > 50
    assert "regolith_viewers_dropped_total 1.0" in out["metrics"]
