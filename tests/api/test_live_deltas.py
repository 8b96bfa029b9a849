"""Frames as deltas against a real server: a snapshot plus every delta after it reproduces the
stream's full state at every step, for a viewer there from the start, one that joins late
and reconnects, while an operator acts at random and viewers ask for resyncs."""

from __future__ import annotations

import asyncio
import json
import random
from typing import Any

import httpx
import pytest
from websockets.asyncio.client import ClientConnection, connect

from app.live.frames import Replica
from tests import aio
from tests.api.conftest import AUTH, LiveServer
from tests.progress import Progress

Json = dict[str, Any]
ENDED = {"completed", "stopped", "stalled", "failed", "timeout", "cancelled"}


class Watcher:
    """One viewer: applies what it receives and notes its state at every `seq`."""

    def __init__(self, url: str, rng: random.Random) -> None:
        self.url = url
        self.rng = rng
        self.states: dict[int, Json] = {}
        self.replica = Replica()
        self.checked_full = 0  # full frames that arrived at the seq the replica was at
        self.frames = 0
        self.bytes: list[int] = []
        self.ended: Json | None = None  # the snapshot of a mission that had ended on joining

    async def run(self, frames: int | None = None) -> None:
        """Watch until the mission ends (or for `frames` frames), then close."""
        async with connect(self.url, max_size=2**24) as ws:
            snap = json.loads(await ws.recv())
            assert snap["type"] == "snapshot"
            if snap["seq"] is None:  # ended before we joined: the stored ending, no deltas
                assert snap["mission"]["status"] in ENDED, snap["mission"]["status"]
                self.ended = snap
                return
            self.replica = Replica()
            self.replica.snapshot(snap)
            self._note()
            seen = 0
            async for raw in ws:
                msg = json.loads(raw)
                if msg["type"] == "status" and msg["status"] in ENDED:
                    return
                if msg["type"] != "frame":
                    continue
                await self._frame(ws, msg, len(raw))
                seen += 1
                if frames is not None and seen >= frames:
                    return

    async def _frame(self, ws: ClientConnection, msg: Json, size: int) -> None:
        self.frames += 1
        self.bytes.append(size)
        if msg.get("full"):
            if msg["seq"] == self.replica.seq:  # the replica must already hold exactly this
                assert self.replica.state() == _full_state(msg)
                self.checked_full += 1
        else:  # the server never skips a delta: a slow viewer's are merged
            assert msg["base"] == self.replica.seq, (msg["base"], self.replica.seq)
        assert self.replica.apply(msg)
        self._note()
        if self.rng.random() < 0.15:
            await ws.send(json.dumps({"type": "resync"}))

    def _note(self) -> None:
        if self.replica.seq is not None:
            self.states[self.replica.seq] = self.replica.state()


def _full_state(msg: Json) -> Json:
    replica = Replica()
    replica.apply(msg)
    return replica.state()


async def _operate(api: httpx.AsyncClient, base: str, rng: random.Random, done: Any) -> list[str]:
    """Random operator actions until `done` is set; every answer is 2xx or a clean 4xx."""
    robots = [r["name"] for r in (await api.get(f"{base}/robots")).json()]
    did: list[str] = []
    actions = [
        ("pause", lambda: api.post(f"{base}/pause")),
        ("resume", lambda: api.post(f"{base}/resume")),
        ("speed", lambda: api.put(f"{base}/speed", json={"speed": rng.choice([150, 400, 800])})),
        ("policy", lambda: api.put(f"{base}/policy", json={"policy": rng.choice([1, 2, 3])})),
        (
            "disable",
            lambda: api.post(
                f"{base}/robots/{rng.choice(robots)}/disable",
                json={"mode": rng.choice(["abrupt", "graceful"])},
            ),
        ),
        ("enable", lambda: api.post(f"{base}/robots/{rng.choice(robots)}/enable")),
        ("add", lambda: api.post(f"{base}/robots", json={"type": rng.choice(["hauler", "scout"])})),
        (
            "task",
            lambda: api.post(
                f"{base}/tasks",
                json={"type": "excavate", "location": [rng.uniform(5, 95), rng.uniform(5, 95)]},
            ),
        ),
    ]
    while not done.is_set():
        await asyncio.sleep(rng.uniform(0.1, 0.4))
        name, call = rng.choice(actions)
        r = await call()
        assert r.status_code < 500, r.text
        did.append(f"{name} {r.status_code}")
    await api.post(f"{base}/resume")
    await api.put(f"{base}/speed", json={"speed": "max"})
    return did


async def _session(server: LiveServer, seed: int) -> tuple[Watcher, list[Watcher], list[str]]:
    rng = random.Random(seed)
    async with httpx.AsyncClient(base_url=server.url, headers=AUTH, timeout=30) as api:
        body = {"seed": seed, "speed": 400, "paused": True, "planner": "straight"}
        mid = (await api.post("/api/missions", json=body)).json()["id"]
        base = f"/api/missions/{mid}"
        url = f"ws://127.0.0.1:{server.port}{base}/live"
        first = Watcher(url, random.Random(rng.random()))
        watching = asyncio.create_task(first.run())
        while not first.states:
            await asyncio.sleep(0.01)
        await api.post(f"{base}/resume")
        done = asyncio.Event()
        operating = asyncio.create_task(_operate(api, base, rng, done))
        late: list[Watcher] = []
        for i in range(2):  # joins mid-mission, leaves, comes back
            wait_s = rng.uniform(0.3, 0.8)
            if i == 0:  # the first joins a few frames in, however slow the machine
                while first.frames < 5:
                    await asyncio.sleep(0.01)
            else:
                await asyncio.sleep(wait_s)
            late.append(Watcher(url, random.Random(rng.random())))
            await late[-1].run(frames=rng.randint(5, 15))
        late.append(Watcher(url, random.Random(rng.random())))
        rest = asyncio.create_task(late[-1].run())
        await asyncio.sleep(1.0)
        done.set()
        did = await operating
        both = asyncio.gather(watching, rest)
        watch = Progress(f"mission {mid}'s watchers to see it end")  # as long as frames come
        while not both.done():
            watch.check((first.frames, late[-1].frames))
            await asyncio.sleep(0.05)
        await both
        stored = (await api.get(f"{base}/robots")).json()
        record = (await api.get(base)).json()
    first.stored = stored  # type: ignore[attr-defined]
    first.record = record  # type: ignore[attr-defined]
    return first, late, did


@pytest.mark.sqlite_only  # the stream, whatever the database
@pytest.mark.parametrize("seed", [11, 12])
def test_snapshot_plus_deltas_is_the_streamed_state_at_every_step(
    server: LiveServer, seed: int
) -> None:
    first, late, did = aio.run(_session(server, seed))
    assert len(did) >= 3 and first.frames > 20
    record = first.record  # type: ignore[attr-defined]
    shared = 0
    assert late[0].ended is None, "the first late viewer joins a few frames in, mid-mission"
    ended = False
    for other in late:
        if other.ended is not None:  # the mission ended before it joined (a loaded machine)
            assert other.ended["mission"]["status"] == record["status"]
            ended = True
            continue
        assert not ended, "a viewer that joined after the mission's end saw it live"
        common = set(other.states) & set(first.states)
        assert common, "a late viewer's seqs are the stream's"
        for seq in common:  # two viewers at the same step hold the same state
            assert other.states[seq] == first.states[seq], seq
        shared += len(common)
    assert shared > 10
    assert first.checked_full + sum(w.checked_full for w in late) > 0
    # the last state streamed is the stored ending, to the stream's precision
    end = first.replica.state()
    stored = {r["name"]: r for r in first.stored}  # type: ignore[attr-defined]
    assert [r["name"] for r in end["robots"]] == list(stored)
    for r in end["robots"]:
        s = stored[r["name"]]
        assert (r["state"], r["load"], r["alive"]) == (s["state"], s["load"], s["alive"])
        assert abs(r["x"] - s["x"]) <= 0.005 + 1e-9 and abs(r["y"] - s["y"]) <= 0.005 + 1e-9
    assert end["status"] == record["status"] and end["t"] == record["sim_time"]
    for key in ("sites_found", "minerals_delivered", "auctions", "bids"):
        assert end["counters"][key] == record["metrics"][key], key
