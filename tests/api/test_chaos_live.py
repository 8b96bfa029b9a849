"""Chaos acceptance: three missions, ten WebSocket viewers, a minute of random operator actions
from a seeded generator, then every robot enabled: every mission completes with every mineral
delivered, and the server never answers 5xx.

The server is the real `regolith serve` in its own process (tests/api/serve_process.py), so
the viewers' reading threads never share its GIL. The generator's seed is printed (pytest
shows it with a failure) and named in every assertion. CI uses a fixed seed;
`REGOLITH_CHAOS_SEED=random` explores and `REGOLITH_CHAOS_SEED=<seed>` repeats
that run's choices (not its timing: what the robots are doing when an action lands depends on
the wall clock).
"""

from __future__ import annotations

import json
import os
import random
import re
import threading
import time
from collections import Counter
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import httpx
import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect

from engine.policies import POLICIES
from tests.api.serve_process import ServeProcess
from tests.progress import wait_progress

Json = dict[str, Any]

CHAOS_S = 60.0  # wall time of random operator actions
VIEWERS = 10
LIVE = ("running", "paused")
# The reference scenario, except that a mission left without progress ends `stalled` only
# after 30,000 s instead of 3,600 s: the chaos may disable every hauler and then set speed
# "max" for a moment (a few thousand simulated seconds at most), which is a legitimate
# operator choice, not a stall to end the mission for. A mission that cannot finish once
# every robot is enabled again still ends `stalled`, with the engine's report, within seconds.
SCENARIO = {"stall_timeout_s": 30_000.0}
KIND_STALLED = "mission_stalled"
QUIET = ("message", "bid")  # event kinds never streamed (docs/service.md)
LEGIT = {200, 201, 409, 422}
# what a legitimate refusal says (numbers, names and punctuation blanked)
REFUSAL = re.compile(
    r"409 robot '\w+ ' is (not disabled|already \w+)"  # a leaving robot: its state
    r"|409 mission has ended \w+ ?"
    r"|409 mission is \w+; it (accepts no commands|cannot be resumed)"
    r"|422 body (location|position) lies in a crater"
)


class Viewer(threading.Thread):
    """One WebSocket viewer reading continuously and checking the stream's order."""

    def __init__(self, ws: ClientConnection, mission_id: int) -> None:
        super().__init__(daemon=True, name=f"viewer-{mission_id}")
        self.mission_id = mission_id
        self.ws = ws
        self.counts: Counter[str] = Counter()
        self.problems: list[str] = []
        self.ended = threading.Event()
        self.end_status: str | None = None
        self.closed: ConnectionClosed | None = None
        self.seqs: list[int] = []  # every event streamed, in order
        self._last_t = -1.0

    def run(self) -> None:
        try:
            while True:
                self._take(json.loads(self.ws.recv()))
        except ConnectionClosed as exc:
            self.closed = exc
        except Exception as exc:  # a bad message or a client error: report, never hang
            self.problems.append(f"{type(exc).__name__}: {exc}")

    def _take(self, msg: Json) -> None:
        kind = msg["type"]
        if not self.counts and kind != "snapshot":
            self.problems.append(f"first message is {kind}, not snapshot")
        self.counts[kind] += 1
        if kind == "snapshot" and msg["mission"]["id"] != self.mission_id:
            self.problems.append(f"snapshot of mission {msg['mission']['id']}")
        elif kind == "event":
            self.seqs.append(msg["event"]["seq"])
        elif kind == "frame":
            if msg["t"] < self._last_t:
                self.problems.append(f"frame at t={msg['t']} after t={self._last_t}")
            self._last_t = msg["t"]
        elif kind == "status" and msg["status"] not in LIVE:
            self.end_status = msg["status"]
            self.ended.set()

    def describe(self) -> str:
        closed = "open" if self.closed is None else f"closed {self.closed}"
        return f"viewer of mission {self.mission_id}: {dict(self.counts)}, {closed}"


class Chaos:
    """Random operator actions on live missions, every answer's status recorded."""

    def __init__(self, api: httpx.Client, rng: random.Random, missions: list[int]) -> None:
        self.api = api
        self.rng = rng
        self.missions = missions
        self.policies = sorted(POLICIES)
        self.codes: Counter[int] = Counter()
        self.by_kind: Counter[tuple[str, int]] = Counter()
        self.refusals: Counter[str] = Counter()  # 4xx details, names and numbers blanked
        self.fives: list[str] = []
        self.unexpected: list[str] = []
        self.actions: list[tuple[str, Callable[[int], None]]] = [
            ("disable", self.disable),
            ("enable", self.enable),
            ("add_robot", self.add_robot),
            ("inject_excavate", self.inject_excavate),
            ("inject_transport", self.inject_transport),
            ("policy", self.policy),
            ("speed", self.speed),
            ("pause_resume", self.pause_resume),
            ("max_burst", self.max_burst),
            ("reads", self.reads),
        ]
        self.weights = [6, 5, 2, 3, 2, 2, 3, 2, 1, 2]

    # -- recording -------------------------------------------------------------------------

    def call(self, kind: str, method: str, path: str, **kw: Any) -> httpx.Response:
        r = self.api.request(method, path, **kw)
        self.codes[r.status_code] += 1
        self.by_kind[(kind, r.status_code)] += 1
        line = f"{method} {path} {kw.get('json')} -> {r.status_code} {r.text[:300]}"
        if 400 <= r.status_code < 500:
            detail = r.json().get("message") or r.json().get("detail")
            self.refusals[f"{r.status_code} {re.sub(r'[-0-9.,:() ]+', ' ', str(detail))}"] += 1
        if r.status_code >= 500:
            self.fives.append(line)
        elif r.status_code not in LEGIT:
            self.unexpected.append(line)
        return r

    def read(self, path: str, **params: Any) -> Any:
        r = self.call("read", "GET", path, params=params)
        return r.json() if r.status_code == 200 else None

    # -- helpers ---------------------------------------------------------------------------

    def robots(self, mid: int) -> list[Json]:
        return self.read(f"/api/missions/{mid}/robots") or []

    def point(self) -> list[float]:
        return [round(self.rng.uniform(0, 100), 3), round(self.rng.uniform(0, 100), 3)]

    def seen_at(self, mid: int, kind: str) -> list[list[float]]:
        page = self.read(f"/api/missions/{mid}/events", kind=kind, limit=1000)
        return [[e["data"]["x"], e["data"]["y"]] for e in (page or {}).get("items", [])]

    # -- actions ---------------------------------------------------------------------------

    def disable(self, mid: int) -> None:
        robots = self.robots(mid)
        up = [r for r in robots if r["enabled"]]
        pool = up if up and self.rng.random() < 0.85 else robots  # sometimes a 409 on purpose
        if pool:
            name = self.rng.choice(pool)["name"]
            mode = self.rng.choice(["graceful", "abrupt"])
            path = f"/api/missions/{mid}/robots/{name}/disable"
            self.call("disable", "POST", path, json={"mode": mode})

    def enable(self, mid: int) -> None:
        robots = self.robots(mid)
        down = [r for r in robots if not r["enabled"]]
        pool = down if down and self.rng.random() < 0.85 else robots
        if pool:
            name = self.rng.choice(pool)["name"]
            self.call("enable", "POST", f"/api/missions/{mid}/robots/{name}/enable")

    def add_robot(self, mid: int) -> None:
        body: Json = {"type": self.rng.choice(["scout", "excavator", "hauler"])}
        if self.rng.random() < 0.5:
            body["position"] = self.point()
        self.call("add_robot", "POST", f"/api/missions/{mid}/robots", json=body)

    def inject_excavate(self, mid: int) -> None:
        sites = self.seen_at(mid, "site_found")
        where = self.rng.choice(sites) if sites and self.rng.random() < 0.7 else self.point()
        body = {"type": "excavate", "location": where}
        self.call("inject", "POST", f"/api/missions/{mid}/tasks", json=body)

    def inject_transport(self, mid: int) -> None:
        spots = self.seen_at(mid, "mineral_dropped") + self.seen_at(mid, "site_found")
        where = self.rng.choice(spots) if spots and self.rng.random() < 0.7 else self.point()
        body = {"type": "transport", "location": where}
        self.call("inject", "POST", f"/api/missions/{mid}/tasks", json=body)

    def policy(self, mid: int) -> None:
        body = {"policy": self.rng.choice(self.policies)}
        self.call("policy", "PUT", f"/api/missions/{mid}/policy", json=body)

    def speed(self, mid: int) -> None:
        speed: float = self.rng.choice([5, 10, 20, 30, 50, 80])
        if self.rng.random() < 0.1:
            speed = 0  # the same as pause
        self.call("speed", "PUT", f"/api/missions/{mid}/speed", json={"speed": speed})

    def pause_resume(self, mid: int) -> None:
        verb = "pause" if self.rng.random() < 0.3 else "resume"
        self.call("pause_resume", "POST", f"/api/missions/{mid}/{verb}")

    def max_burst(self, mid: int) -> None:
        """A moment at "max" (an action on another mission meanwhile), then a finite speed."""
        self.call("speed", "PUT", f"/api/missions/{mid}/speed", json={"speed": "max"})
        self.step(self.rng.choice(self.missions), nested=True)
        speed = self.rng.choice([10, 20])
        self.call("speed", "PUT", f"/api/missions/{mid}/speed", json={"speed": speed})

    def reads(self, mid: int) -> None:
        self.read(f"/api/missions/{mid}")
        self.read(f"/api/missions/{mid}/auctions", status="open")
        self.read("/api/missions", limit=10)

    def step(self, mid: int, nested: bool = False) -> None:
        kind, action = self.rng.choices(self.actions, self.weights)[0]
        if not (nested and kind == "max_burst"):
            action(mid)

    def run(self, seconds: float) -> int:
        """Random actions for `seconds` of wall time; sometimes two back to back."""
        n = 0
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            mid = self.rng.choice(self.missions)
            self.step(mid)
            n += 1
            if self.rng.random() < 0.2:  # a second action at once, maybe on another mission
                other = mid if self.rng.random() < 0.6 else self.rng.choice(self.missions)
                self.step(other, nested=True)
                n += 1
            # an operator's think time: pacing, not synchronization
            time.sleep(self.rng.uniform(0.05, 0.5))
        return n


DEFAULT_SEED = 2026_11_23


def _settle(api: httpx.Client, mid: int, seed: int) -> None:
    """Enable every robot that is down, then let the mission run flat out."""
    base = f"/api/missions/{mid}"
    if api.get(base).json()["status"] not in LIVE:
        return
    for robot in api.get(f"{base}/robots").json():
        if not robot["enabled"]:
            r = api.post(f"{base}/robots/{robot['name']}/enable")
            assert r.status_code == 200, f"seed {seed}: enable {robot['name']}: {r.text}"
    for r in (api.post(f"{base}/resume"), api.put(f"{base}/speed", json={"speed": "max"})):
        assert r.status_code == 200, f"seed {seed}: {r.request.url.path}: {r.text}"


def _streamed_seqs(api: httpx.Client, mid: int) -> list[int]:
    """The stored events a viewer is sent, by seq."""
    seqs: list[int] = []
    after = -1
    while True:
        params = {"after": after, "limit": 1000}
        page = api.get(f"/api/missions/{mid}/events", params=params).json()
        seqs += [e["seq"] for e in page["items"] if e["kind"] not in QUIET]
        if page["next_after"] is None:
            return seqs
        after = page["next_after"]


def _server_errors(log: str) -> list[str]:
    bad = []
    for line in log.splitlines():
        try:
            level = json.loads(line).get("level")
        except ValueError:
            level = "ERROR" if "Traceback" in line else None
        if level in ("ERROR", "CRITICAL"):
            bad.append(line[:500])
    return bad


@pytest.mark.slow  # about 65 s; CI runs every test (`make test`: pytest -q)
@pytest.mark.sqlite_only  # the engine's liveness under a live server: the database's share is
# covered on PostgreSQL by the concurrency, crash and restart tests; twice would cost CI ~1 min
def test_chaos_three_missions_ten_viewers_then_everything_completes(tmp_path: Path) -> None:
    # a fixed seed by default, so CI repeats the same choices (their timing still varies with
    # the wall clock); REGOLITH_CHAOS_SEED=random explores, any number repeats that one
    chosen = os.environ.get("REGOLITH_CHAOS_SEED") or str(DEFAULT_SEED)
    seed = random.SystemRandom().randrange(2**32) if chosen == "random" else int(chosen)
    print(f"\nchaos seed {seed} (REGOLITH_CHAOS_SEED={seed} repeats its choices)")
    rng = random.Random(seed)
    started = time.monotonic()
    args = ("--log-level", "warning", "--log-format", "json")
    with ServeProcess(tmp_path, *args) as srv, srv.client() as api, ExitStack() as stack:
        missions: list[int] = []
        for policy in rng.sample(sorted(POLICIES), 3):
            body = {
                "seed": rng.randrange(2**31),
                "policy": policy,
                "speed": rng.choice([15, 20, 25]),
                "paused": True,
                "scenario": SCENARIO,
            }
            r = api.post("/api/missions", json=body)
            assert r.status_code == 201, f"seed {seed}: {r.text}"
            missions.append(r.json()["id"])
        viewers = []
        for i in range(VIEWERS):
            mid = missions[i % len(missions)]
            url = f"ws://127.0.0.1:{srv.port}/api/missions/{mid}/live"
            viewers.append(Viewer(stack.enter_context(connect(url, max_size=2**24)), mid))
        for v in viewers:
            v.start()
        for mid in missions:
            assert api.post(f"/api/missions/{mid}/resume").status_code == 200

        chaos = Chaos(api, rng, missions)
        n = chaos.run(CHAOS_S)
        for mid in missions:
            m = api.get(f"/api/missions/{mid}").json()
            print(f"mission {mid} after the chaos: {m['status']} at t={m['sim_time']:.0f}")
        print(f"{n} actions; statuses {dict(chaos.codes)}; by kind {dict(chaos.by_kind)}")
        print("refusals:", "\n  ".join(f"{n} x {r}" for r, n in chaos.refusals.items()))
        tally = f"seed {seed}: {dict(chaos.by_kind)}"
        assert not chaos.fives, f"seed {seed}: 5xx answers:\n" + "\n".join(chaos.fives)
        assert not chaos.unexpected, f"seed {seed}: unexpected:\n" + "\n".join(chaos.unexpected)
        odd = [r for r in chaos.refusals if not REFUSAL.fullmatch(r)]
        assert not odd, f"seed {seed}: refusals for no legitimate reason: {odd}"
        for kind in ("disable", "enable", "add_robot", "inject", "policy", "speed"):
            ok = chaos.by_kind[(kind, 200)] + chaos.by_kind[(kind, 201)]
            assert ok > 0, f"no {kind} action succeeded ({tally})"

        for mid in missions:
            _settle(api, mid, seed)

        def ended() -> list[Json] | None:
            records = [api.get(f"/api/missions/{mid}").json() for mid in missions]
            return records if all(m["status"] not in LIVE for m in records) else None

        records = wait_progress(
            ended,
            lambda: [api.get(f"/api/missions/{mid}").json()["sim_time"] for mid in missions],
            f"seed {seed}: missions {missions} to end",
            every=0.2,
        )
        for m in records:
            metrics = m["metrics"]
            where = f"seed {seed}, mission {m['id']} (seed {m['seed']}, {m['initial_policy']})"
            detail = m["error"]
            if m["status"] != "completed":  # what is stuck, and the history to replay it
                page = api.get(f"/api/missions/{m['id']}/events", params={"kind": KIND_STALLED})
                for ev in page.json()["items"]:
                    report = ev["data"]
                    busy = [r for r in report["robots"] if r["state"] != "idle"]
                    detail = f"{report['minerals']}, busy {busy}, open {report['open_auctions']}"
                actions = api.get(f"/api/missions/{m['id']}/actions").json()
                replay = [{k: a[k] for k in ("t", "kind", "args")} for a in actions if a["replay"]]
                print(f"{where} {m['status']}; its replayable actions:\n{json.dumps(replay)}")
            assert m["status"] == "completed", f"{where}: {m['status']} {detail}"
            assert metrics["minerals_delivered"] == metrics["minerals_total"] == 64, where
            assert metrics["sites_found"] == metrics["sites_total"], where

        # every viewer saw its mission end, still connected, its stream in order
        for v in viewers:
            assert v.ended.wait(15), f"seed {seed}: never saw the end: {v.describe()}"
            assert v.end_status == "completed", v.describe()
            assert v.counts["frame"] > 0 and v.counts["event"] > 0, v.describe()
            assert v.closed is None and not v.problems, f"{v.describe()}: {v.problems}"
        streamed = {mid: _streamed_seqs(api, mid) for mid in missions}
        for v in viewers:  # each joined before the first step: it saw every streamed event
            assert v.seqs == streamed[v.mission_id], f"seed {seed}: {v.describe()}"
        for v in viewers:
            v.ws.close()
        for v in viewers:
            v.join(10)
            assert not v.is_alive(), v.describe()
            assert v.closed is not None and v.closed.rcvd is not None, v.describe()
            assert v.closed.rcvd.code == 1000, v.describe()
            assert not v.problems, f"{v.describe()}: {v.problems}"
        assert api.get("/api/health").json()["status"] == "ok"
        errors = _server_errors(srv.stderr())
    assert not errors, f"seed {seed}: the server logged errors:\n" + "\n".join(errors)
    print(f"wall time {time.monotonic() - started:.1f} s")
