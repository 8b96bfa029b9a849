"""The live stream against a real server: snapshot, frames, auctions, events, status."""

from __future__ import annotations

import asyncio
import base64
import json
import os
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import pytest
import websockets

from tests.api.conftest import LiveServer, all_pages, recv, recv_until
from tests.api.serve_process import ServeProcess

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


def _stalled_viewer(port: int, mission_id: int) -> socket.socket:
    """A raw WebSocket client that completes the handshake and then never reads again.

    A small receive buffer and segment size (536 bytes, like a slow remote link) keep what the
    kernel holds for it to ~100 KB; with loopback's 64 KB segments the server's send buffer
    autotunes to ~2.8 MB, which takes many seconds to fill."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_MAXSEG, 536)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET /api/missions/{mission_id}/live HTTP/1.1\r\nHost: 127.0.0.1\r\n"
            "Upgrade: websocket\r\nConnection: Upgrade\r\n"
            f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    assert b" 101 " in sock.recv(1024)
    return sock


@dataclass
class Window:
    """What the reading viewers saw during one measured window."""

    delays_ms: list[float]  # receive time - the frame's server `wall` stamp, every reader
    frames_per_reader: float
    sim_rate: float  # simulated seconds per wall second, from the frames' (wall, t)
    viewers: list[int]  # the server's viewer count for the mission, sampled each second
    backlog: list[int]  # ordered messages waiting for its slowest viewer, sampled each second

    def q(self, q: float) -> float:
        ordered = sorted(self.delays_ms)
        return ordered[min(len(ordered) - 1, int(q * len(ordered)))]

    def line(self, name: str) -> str:
        return (
            f"  {name:28s} frame delay p50 {self.q(0.5):5.1f} ms  p99 {self.q(0.99):6.1f} ms  "
            f"{self.frames_per_reader:4.1f} frames/s per reader  "
            f"{self.sim_rate:4.0f} sim s per wall s  viewers {self.viewers}"
        )


SLOW_SPEED = 300.0  # well inside what the engine does on a loaded machine: pacing, not capacity
SLOW_READERS, SLOW_WINDOW_S, SLOW_HZ = 10, 3.0, 20
_FRAME = '{"type":"frame",'  # frames are recognised without parsing every event


def _gauge(metrics: str, name: str, mission_id: int) -> int:
    prefix = f'{name}{{mission="{mission_id}"}} '
    found = [x[len(prefix) :] for x in metrics.splitlines() if x.startswith(prefix)]
    return int(float(found[0])) if found else 0


async def _stall_session(port: int, api: httpx.Client, mid: int) -> dict[str, Window]:
    """Ten readers watch `mid` through three windows: clean; with a stalled viewer whose
    socket is full (the server's sends to it block and its queue grows); clean again after
    a spell at "max" filled its queue and the server dropped it."""
    url = f"ws://127.0.0.1:{port}/api/missions/{mid}/live"
    seen: list[tuple[int, float, float, float]] = []  # (reader, wall, t, delay ms)

    async def read(ws: websockets.ClientConnection, reader: int) -> None:
        async for raw in ws:
            if isinstance(raw, str) and raw.startswith(_FRAME):
                now, frame = time.time(), json.loads(raw)
                seen.append((reader, frame["wall"], frame["t"], (now - frame["wall"]) * 1000))

    async def call(method: str, path: str, **kw: Any) -> httpx.Response:
        r = await asyncio.to_thread(api.request, method, path, **kw)
        r.raise_for_status()
        return r

    async def gauges() -> tuple[int, int]:
        text = (await call("GET", "/api/metrics")).text
        return _gauge(text, "regolith_viewers", mid), _gauge(text, "regolith_viewer_backlog", mid)

    async def until(done: Callable[[int, int], bool]) -> None:
        """Wait for the viewers/backlog gauges to say so."""
        deadline = time.monotonic() + 30
        while not done(*await gauges()):
            assert time.monotonic() < deadline, "the stalled viewer never filled up"
            await asyncio.sleep(0.05)

    async def window() -> Window:
        start, counts = time.time(), []
        for _ in range(int(SLOW_WINDOW_S)):
            await asyncio.sleep(1.0)
            counts.append(await gauges())
        end = time.time()
        mine = [(r, w, t, d) for r, w, t, d in seen if start <= w < end]
        ticks = [(w, t) for r, w, t, _ in mine if r == 0]
        (w0, t0), (w1, t1) = ticks[0], ticks[-1]
        return Window(
            delays_ms=[d for *_, d in mine],
            frames_per_reader=len(mine) / SLOW_READERS / (end - start),
            sim_rate=(t1 - t0) / (w1 - w0),
            viewers=[v for v, _ in counts],
            backlog=[b for _, b in counts],
        )

    sockets = [await websockets.connect(url, max_size=2**24) for _ in range(SLOW_READERS)]
    for ws in sockets:
        assert json.loads(await ws.recv())["type"] == "snapshot"
    tasks = [asyncio.create_task(read(ws, i)) for i, ws in enumerate(sockets)]
    await call("POST", f"/api/missions/{mid}/resume")
    await asyncio.sleep(0.5)
    out = {"before": await window()}
    stall = await asyncio.to_thread(_stalled_viewer, port, mid)
    await until(lambda viewers, backlog: backlog > 50)  # its sends block: it queues
    out["stalled"] = await window()
    await call("PUT", f"/api/missions/{mid}/speed", json={"speed": "max"})
    await until(lambda viewers, backlog: viewers == SLOW_READERS)  # its queue filled: dropped
    await call("PUT", f"/api/missions/{mid}/speed", json={"speed": SLOW_SPEED})
    await asyncio.sleep(0.5)  # settle at the test speed again
    out["after"] = await window()
    stall.close()
    # close while the readers keep draining: a client that stops reading (its own queue
    # full) would not see the server's close frame until its close timeout
    await asyncio.gather(*(ws.close() for ws in sockets))
    await asyncio.gather(*tasks)
    return out


def test_a_stalled_viewer_never_slows_the_mission_or_other_viewers(tmp_path: Path) -> None:
    """Issue 7: ten reading viewers' frame delay and the mission's pace, with and without an
    eleventh viewer that never reads (a raw socket that stops after the handshake).

    The server runs in its own process (the readers never share its GIL). One long mission
    at 300x, 20 frames/s, three 3 s windows (~600 frames each): before the stalled viewer
    connects, while its socket is full and its queue grows (the server's sends to it block),
    and after the server dropped it (a spell at "max" fills its 4,000-message queue). The
    stalled window is compared with the two clean ones pooled, which bracket it in time, so
    a load spike on a shared machine hits both sides.
    Medians are compared (2x plus a 20 ms floor): p99 on a loaded 2-core machine is
    scheduler noise of tens to hundreds of ms either way, so it is printed, not asserted.
    """
    body = {"seed": 8, "speed": SLOW_SPEED, "paused": True, "scenario": LONG, "planner": "straight"}
    env = {"REGOLITH_FRAME_HZ": str(SLOW_HZ), "REGOLITH_VIEWER_QUEUE": "4000"}
    with ServeProcess(tmp_path, "--log-level", "warning", **env) as srv, srv.client() as api:
        mid = api.post("/api/missions", json=body).json()["id"]
        runs = asyncio.run(_stall_session(srv.port, api, mid))
        metrics = api.get("/api/metrics").text
        api.post(f"/api/missions/{mid}/stop").raise_for_status()
    before, stalled, after = runs["before"], runs["stalled"], runs["after"]
    clean = Window(
        before.delays_ms + after.delays_ms,
        (before.frames_per_reader + after.frames_per_reader) / 2,
        (before.sim_rate + after.sim_rate) / 2,
        before.viewers + after.viewers,
        before.backlog + after.backlog,
    )
    print(f"\nslow client: {SLOW_READERS} readers at {SLOW_SPEED:g}x, {SLOW_HZ} frames/s")
    for name, run in (("before", before), ("stalled viewer attached", stalled), ("after", after)):
        print(run.line(name))
    print(f"  stalled viewer's backlog during its window: {stalled.backlog}")

    assert stalled.viewers == [SLOW_READERS + 1] * len(stalled.viewers)  # attached throughout
    assert all(b > 0 for b in stalled.backlog)  # and not being served: its sends were blocked
    assert clean.viewers == [SLOW_READERS] * len(clean.viewers)
    assert "regolith_viewers_dropped_total 1.0" in metrics  # dropped once its queue filled
    assert stalled.q(0.5) <= 2 * clean.q(0.5) + 20
    assert stalled.frames_per_reader >= 0.5 * clean.frames_per_reader
    # the mission kept its pace, stall or not (the first check only guards the measurement)
    assert clean.sim_rate > 0.8 * SLOW_SPEED
    assert stalled.sim_rate > 0.9 * min(clean.sim_rate, SLOW_SPEED)
