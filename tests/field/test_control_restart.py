"""Mission control is not a single point of failure (docs/field.md, "What survives what").

A field mission on a real server (uvicorn in a subprocess); the server is SIGKILLed, and
later sent SIGTERM, mid-mission. Each time the world's process and the agents mine on
(deliveries seen on the bus, in frames signed by the world); 30 s later a new server starts
on the same database, attaches to the mission again within seconds, and runs it on; 64/64.
Its stored records have no gap and no duplicate: every delivery once, each life's reports
once, events numbered without a hole, the gaps' events stored too.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import random
import signal
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from field.transport import open_session
from field.trust import Opener
from field.wire import event_key
from tests.e2e.conftest import Server
from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time
from tests.progress import wait_progress

pytestmark = pytest.mark.fleet

DOWN_S = 30.0
"""How long no server runs (the issue's scenario: restarted 30 s later)."""


class BusWatch:
    """The world's signed events on the bus while no server listens: what a robot or an
    operator's own tool would see."""

    def __init__(self, mission: str, endpoint: str, anchor: bytes) -> None:
        self.opener = Opener(mission, anchor, "test")
        self.key = event_key(mission, "world")
        self.delivered: list[float] = []
        self.session = open_session(connect=endpoint)
        self._lock = threading.Lock()
        self.sub = self.session.declare_subscriber(self.key, self._on)

    def _on(self, sample: Any) -> None:
        opened = self.opener.admit(self.key, sample.payload.to_bytes(), 1 << 20)
        if opened is None or opened.sender != "world":
            return
        data = json.loads(opened.body)
        if data.get("event") == "delivered":
            with self._lock:
                self.delivered.append(float(data["t"]))

    def close(self) -> None:
        self.sub.undeclare()
        self.session.close()  # type: ignore[no-untyped-call]


def _link(db: Path, mid: int) -> dict[str, Any]:
    with contextlib.closing(sqlite3.connect(db)) as con:
        con.row_factory = sqlite3.Row
        row = con.execute("select * from field_links where mission_id = ?", (mid,)).fetchone()
        return dict(row)


def _row(api: httpx.Client, mid: int) -> dict[str, Any]:
    out: dict[str, Any] = api.get(f"/missions/{mid}").json()
    return out


def _stop_processes(link: dict[str, Any] | None) -> None:
    """The world's process (and with it its agents), whatever the test left running."""
    pid = (link or {}).get("world_pid")
    if not pid:
        return
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal.SIGTERM)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            os.kill(pid, 0)
            time.sleep(0.2)
        os.killpg(pid, signal.SIGKILL)


def test_a_field_mission_outlives_its_server(tmp_path: Path) -> None:
    """SIGKILLed after three deliveries, SIGTERMed three deliveries after its return: each
    time the robots mine on (deliveries on the bus), and a new server 30 s later takes the
    mission back at once."""
    srv = Server(tmp_path).start()
    db = tmp_path / "regolith.db"
    link: dict[str, Any] | None = None
    gaps: list[tuple[float, float]] = []
    try:
        with one_field_mission_at_a_time(), srv.api() as api:
            res = api.post(
                "/missions",
                # 25x: both 30 s gaps (750 s of mission time each) fall inside the mission
                json={"policy": "nearest", "seed": 0, "speed": paced(25), "field": True},
            )
            assert res.status_code == 201, res.text
            mid = res.json()["id"]
            link = _link(db, mid)
            for how in (signal.SIGKILL, signal.SIGTERM):
                after = _row(api, mid)["metrics"]["minerals_delivered"] + 3
                wait_progress(
                    lambda n=after: _row(api, mid)["metrics"]["minerals_delivered"] >= n,
                    lambda: _row(api, mid)["sim_time"],
                    f"{after} deliveries",
                )
                gaps.append(_away(srv, db, mid, link, how))
                t0 = time.monotonic()
                assert srv._launch(), srv.log_text()  # a new server on the same database
                back = _row(api, mid)
                print(f"\n{how.name}: running again {time.monotonic() - t0:.1f} s after the start")
                assert back["status"] == "running", back
            done = wait_progress(
                lambda: ((r := _row(api, mid))["status"] != "running" and r) or None,
                lambda: _row(api, mid)["sim_time"],
                f"field mission {mid} after the restarts",
            )
            assert done["status"] == "completed", done
            assert done["metrics"]["minerals_delivered"] == 64
        _check_records(db, mid, gaps)
    finally:
        srv.stop()
        _stop_processes(link)


def _away(
    srv: Server, db: Path, mid: int, link: dict[str, Any], how: signal.Signals
) -> tuple[float, float]:
    """The server goes (`how`); the world and its robots do not: deliveries on the bus for
    `DOWN_S`. The mission time the server last stored, and of the last delivery seen."""
    assert srv.proc is not None
    srv.proc.send_signal(how)
    srv.proc.wait(timeout=60)
    srv.proc = None
    with contextlib.closing(sqlite3.connect(db)) as con:
        status, down_at = con.execute(
            "select status, sim_time from missions where id = ?", (mid,)
        ).fetchone()
    assert status == "running", (how.name, status)  # not interrupted: it goes on
    watch = BusWatch(link["key_space"], link["endpoint"], _anchor(link["authority"]))
    try:
        time.sleep(DOWN_S)
        seen = list(watch.delivered)
    finally:
        watch.close()
    assert seen, f"{how.name}: no delivery on the bus while no server ran"
    return down_at, max(seen)


def _anchor(secret_b64: str) -> bytes:
    from field.trust import Authority

    return Authority.restore("m", base64.b64decode(secret_b64), 1).anchor


def _check_records(db: Path, mid: int, gaps: list[tuple[float, float]]) -> None:
    """No gap, no duplicate: the records a field mission must have, whatever stopped its
    servers; `gaps`: (from, to) mission times no server ran, whose events must be stored."""
    with contextlib.closing(sqlite3.connect(db)) as con:
        q = con.execute
        seqs = [s for (s,) in q("select seq from events where mission_id=? order by seq", (mid,))]
        assert seqs == list(range(len(seqs)))  # numbered without a hole
        delivered = [
            json.loads(d)["delivered"]
            for (d,) in q("select data from events where mission_id=? and kind='delivered'", (mid,))
        ]
        assert sorted(delivered) == list(range(1, 65))  # every delivery once
        dup = q(
            "select source, rseq, count(*) from events where mission_id=? and source is not null "
            "group by source, rseq having count(*) > 1",
            (mid,),
        ).fetchall()
        assert dup == []  # no report stored twice
        world = [
            r
            for (r,) in q(
                "select rseq from events where mission_id=? and source like 'world#%' order by seq",
                (mid,),
            )
        ]
        assert world == list(range(len(world)))  # the world reports only events: all of them
        lives = q(
            "select source, group_concat(rseq) from events where mission_id=? and source is not "
            "null group by source",
            (mid,),
        ).fetchall()
        for source, rseqs in lives:  # each life's reports in its own order
            ns = [int(n) for n in rseqs.split(",")]
            assert ns == sorted(ns), source
        for down_at, seen_at in gaps:
            between = q(
                "select count(*), count(distinct source) from events where mission_id=? and "
                "t > ? and t < ? and source is not null",
                (mid, down_at, seen_at),
            ).fetchone()
            assert between[0] > 0 and between[1] > 3, between  # what happened meanwhile
        if gaps:
            assert q(
                "select count(*) from events where mission_id=? and kind='control_returned'",
                (mid,),
            ).fetchone() == (len(gaps),)
        closed = q(
            "select json_extract(data, '$.auction_id'), count(*) from events where mission_id=? "
            "and kind='auction_closed' group by 1 having count(*) > 1",
            (mid,),
        ).fetchall()
        assert closed == []  # auctions closed once


SEEDS = [int(s) for s in os.environ.get("REGOLITH_FIELD_RESTART_SEEDS", "11").split(",")]


@pytest.mark.parametrize("seed", SEEDS)
def test_random_operator_actions_across_server_restarts(tmp_path: Path, seed: int) -> None:
    """Pauses, new speeds, robot failures and rejoins, and server restarts (SIGKILL or SIGTERM)
    in a seeded random order. Throughout: no delivery while paused (also across a restart);
    a restarted server shows the mission as the old one left it (paused stays paused). At the
    end: 64/64, and the records of `_check_records` (no gap, no duplicate)."""
    rng = random.Random(seed)
    print(f"\nfield restart chaos seed {seed} (REGOLITH_FIELD_RESTART_SEEDS={seed} repeats it)")
    srv = Server(tmp_path).start()
    db = tmp_path / "regolith.db"
    link: dict[str, Any] | None = None
    try:
        with one_field_mission_at_a_time(), srv.api() as api:
            base = paced(50)
            res = api.post(
                "/missions", json={"policy": "nearest", "seed": seed, "speed": base, "field": True}
            )
            assert res.status_code == 201, res.text
            mid = res.json()["id"]
            link = _link(db, mid)
            held: int | None = None  # minerals delivered when paused
            restarts = 0
            # every kind at least once (twice the ones that interact most), in a random order
            kinds = ["pause", "speed", "kill", "enable", "restart"]
            plan = [*kinds, "pause", "kill", "restart", *rng.choices(kinds, k=2)]
            rng.shuffle(plan)
            for step, kind in enumerate(plan):
                row = _row(api, mid)
                if row["status"] not in ("running", "paused"):
                    break
                delivered = row["metrics"]["minerals_delivered"]
                if held is not None:
                    assert delivered == held, f"step {step}: a delivery while paused: {row}"
                print(f"  step {step}: t={row['sim_time']:.0f} {row['status']} {kind}")
                if kind == "pause" and row["status"] == "running":
                    assert api.post(f"/missions/{mid}/pause").status_code == 200
                    held = _row(api, mid)["metrics"]["minerals_delivered"]
                elif kind == "pause":
                    assert api.post(f"/missions/{mid}/resume").status_code == 200
                    held = None
                elif kind == "speed":
                    speed = rng.choice([base / 2, base])
                    assert api.put(f"/missions/{mid}/speed", json={"speed": speed}).is_success
                elif kind == "kill":
                    alive = [
                        r["name"] for r in api.get(f"/missions/{mid}/robots").json() if r["alive"]
                    ]
                    name = rng.choice(alive)
                    res = api.post(f"/missions/{mid}/robots/{name}/disable")
                    assert res.status_code == 200, res.text
                elif kind == "enable":
                    down = [
                        r["name"]
                        for r in api.get(f"/missions/{mid}/robots").json()
                        if not r["alive"]
                    ]
                    if down:
                        res = api.post(f"/missions/{mid}/robots/{rng.choice(down)}/enable")
                        assert res.status_code == 200, res.text
                else:
                    before = _row(api, mid)["status"]
                    how = rng.choice([signal.SIGKILL, signal.SIGTERM])
                    assert srv.proc is not None
                    srv.proc.send_signal(how)
                    srv.proc.wait(timeout=60)
                    srv.proc = None
                    time.sleep(rng.uniform(1, 6))
                    assert srv._launch(), srv.log_text()
                    restarts += 1
                    after = _row(api, mid)
                    assert after["status"] == before, (how.name, before, after)
                time.sleep(rng.uniform(0.5, 3))
            # the end: everyone back, time moving, run to the end
            for r in api.get(f"/missions/{mid}/robots").json():
                if not r["alive"]:
                    api.post(f"/missions/{mid}/robots/{r['name']}/enable")
            if _row(api, mid)["status"] == "paused":
                assert api.post(f"/missions/{mid}/resume").status_code == 200
            done = wait_progress(
                lambda: (
                    ((r := _row(api, mid))["status"] not in ("running", "paused") and r) or None
                ),
                lambda: _row(api, mid)["sim_time"],
                f"field mission {mid} (seed {seed})",
            )
            assert done["status"] == "completed", done
            assert done["metrics"]["minerals_delivered"] == 64
            print(f"  completed after {restarts} server restart(s)")
        _check_records(db, mid, [])
    finally:
        srv.stop()
        _stop_processes(link)
