"""A field mission under attack, beside a simulated one, on a real server (docs/field.md,
"Trust"). Two hostile processes join the field mission's Zenoh endpoint, one with no
credential and one holding a real credential of another robot (`hauler-7`, issued as for a
robot on another machine), and try every class of forgery (tests/field/hostile_peer.py).

Every forgery is refused and counted; the field mission (the compact one of
tests/field/compact.py) completes with every mineral delivered and the records of an
unattacked run (every auction held by a robot of the mission, every delivery once, the policy
unchanged); the simulated mission's frames and stored events go on; /api/health answers
throughout. Then the server-wide process budget, against the same kind of server.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.api.conftest import LiveServer, all_pages, make_settings
from tests.field.compact import COMPACT, compact_scenario
from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time
from tests.progress import REQUEST_S, wait_progress


def _until_done(api: httpx.Client, mid: int, runner: Any) -> dict[str, Any]:
    """The mission's record once it ends; fails only if the field stops changing (minerals
    delivered, sites found, cells scanned: a field mission's clock always moves)."""

    def ended() -> dict[str, Any] | None:
        row: dict[str, Any] = api.get(f"/api/missions/{mid}").json()
        return row if row["status"] != "running" else None

    def field() -> Any:
        lm = runner.live.get(mid)
        return None if lm is None else lm.mission.fleet.world.status()

    def progress() -> Any:
        st = field()
        return st and (st["delivered"], st["sites_found"], st["scanned"], st["aboard"])

    return wait_progress(ended, progress, f"field mission {mid}", every=0.5)


def _events(api: httpx.Client, mid: int) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    after: int | None = -1
    while after is not None:
        page = api.get(f"/api/missions/{mid}/events", params={"after": after, "limit": 1000})
        out += page.json()["items"]
        after = page.json()["next_after"]
    return out


class Watch(threading.Thread):
    """A viewer of the simulated mission, and a prober of /api/health, while the attack runs."""

    def __init__(self, live: LiveServer, mid: int) -> None:
        super().__init__(daemon=True)
        self.live, self.mid = live, mid
        self.frames: list[float] = []
        self.health: list[float] = []
        self.stop = threading.Event()

    def run(self) -> None:
        with self.live.ws(self.mid) as ws, httpx.Client(base_url=self.live.url) as api:
            while not self.stop.is_set():
                msg = json.loads(ws.recv(timeout=30))
                if msg["type"] == "frame":
                    self.frames.append(time.monotonic())
                if len(self.frames) % 10 == 0:
                    t0 = time.monotonic()
                    assert api.get("/api/health", timeout=REQUEST_S).status_code == 200
                    self.health.append(time.monotonic() - t0)


def _attack(endpoint: str, mission: str, credential: Path | None) -> subprocess.Popen[bytes]:
    cmd = [sys.executable, "-m", "tests.field.hostile_peer", "--endpoint", endpoint]
    cmd += ["--mission", mission, "--rounds", "3"]
    if credential is not None:
        cmd += ["--credential", str(credential)]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE)


@pytest.mark.fleet
def test_a_hostile_peer_changes_nothing(tmp_path: Path) -> None:
    with one_field_mission_at_a_time():
        live = LiveServer(make_settings(tmp_path, frame_hz=10)).start()
        try:
            _attacked(live, tmp_path)
        finally:
            live.stop()


def _attacked(live: LiveServer, tmp_path: Path) -> None:
    runner = live._server.config.app.state.services.runner  # type: ignore[union-attr]
    with live.client() as api:
        other = api.post("/api/missions", json={"seed": 5, "speed": 5}).json()["id"]
        res = api.post(
            "/api/missions",
            json={
                "policy": "nearest",
                "seed": 0,
                "speed": paced(50.0),
                "field": True,
                "scenario": COMPACT,
            },
        )
        assert res.status_code == 201, res.text
        mid = res.json()["id"]
        fleet = runner.live[mid].mission.fleet
        cred = tmp_path / "hauler-7.cred"  # as `regolith fleet up --issue hauler-7` writes it
        cred.write_text(fleet.credential("hauler-7").to_json())
        watch = Watch(live, other)
        watch.start()
        wait_progress(
            lambda: api.get(f"/api/missions/{mid}").json()["sim_time"] >= 150,
            lambda: api.get(f"/api/missions/{mid}").json()["sim_time"],
            "the field mission to start",
        )
        events_before = api.get(f"/api/missions/{other}/events", params={"limit": 1}).json()
        attackers = [_attack(fleet.endpoint, fleet.mission, c) for c in (None, cred)]
        outs = [json.loads(p.communicate(timeout=600)[0]) for p in attackers]
        frames_in_attack = len(watch.frames)
        row = _until_done(api, mid, runner)
        watch.stop.set()
        watch.join(timeout=60)

        # nothing forged was accepted, and all of it was counted
        assert all(o["sent"] > 100 and o["accepted"] == [] for o in outs), outs
        detail = api.get(f"/api/missions/{mid}").json()
        metrics = detail["metrics"]
        assert row["status"] == "completed", row
        compact = compact_scenario()
        found = (metrics["minerals_delivered"], metrics["sites_found"])
        assert found == (compact.minerals, compact.sites), metrics
        dropped = metrics["rejections"]
        reasons = dropped["by_reason"]
        for reason in ("unsigned", "stranger", "impersonation", "oversized", "replayed"):
            assert reasons.get(reason, 0) > 0, (reason, dropped)
        assert dropped["world_refused"] > 0 and sum(dropped["agents"].values()) > 0, dropped
        assert "hauler-7" in dropped["by_sender"]
        scrape = httpx.get(f"{live.url}/api/metrics").text
        assert 'regolith_field_dropped_total{reason="unsigned"}' in scrape

        # the records are an unattacked run's: every auction held by a robot of the mission,
        # every award to one, the policy never switched, each delivery once
        members = {r["name"] for r in api.get(f"/api/missions/{mid}/robots").json()}
        assert "hauler-7" not in members and "hauler-99" not in members
        auctions = all_pages(api, f"/api/missions/{mid}/auctions")
        assert auctions and all(a["auctioneer"] in members | {"operator"} for a in auctions)
        assert all(a["allocated_to"] in members for a in auctions if a["allocated_to"] is not None)
        assert detail["policies"] == ["nearest"] and detail["policy"] == "nearest"
        events = _events(api, mid)
        assert sum(e["kind"] == "delivered" for e in events) == compact.minerals
        assert all(isinstance(e["t"], int | float) for e in events)

        # the simulated mission beside it went on all along
        assert frames_in_attack > 0 and len(watch.frames) > frames_in_attack
        events_after = api.get(f"/api/missions/{other}/events", params={"limit": 1}).json()
        assert events_after["total"] > events_before["total"]
        assert watch.health, "health was never probed"
        print(f"health: {len(watch.health)} probes, max {max(watch.health) * 1000:.0f} ms")
        print(f"dropped: {json.dumps(dropped)}")


@pytest.mark.fleet
def test_field_robots_count_against_the_servers_process_budget(tmp_path: Path) -> None:
    """A budget of 13 agent processes holds one reference field mission (twelve robots and
    its operator console), and nothing more until it stops."""
    with one_field_mission_at_a_time():
        live = LiveServer(make_settings(tmp_path, field_processes=13)).start()
        try:
            with live.client() as api:
                body = {"policy": "nearest", "seed": 0, "speed": 20, "field": True}
                first = api.post("/api/missions", json=body)
                assert first.status_code == 201, first.text
                mid = first.json()["id"]
                for res in (
                    api.post(f"/api/missions/{mid}/robots", json={"type": "hauler"}),
                    api.post("/api/missions", json=body),
                ):
                    assert res.status_code == 429, res.text
                    assert "field_processes" in res.json()["detail"], res.text
                killed = api.post(
                    f"/api/missions/{mid}/robots/hauler-1/disable", json={"mode": "abrupt"}
                )
                assert killed.status_code == 200, killed.text
                back = api.post(f"/api/missions/{mid}/robots/hauler-1/enable")
                assert back.status_code == 200, back.text  # its place was free again
                assert api.post(f"/api/missions/{mid}/stop").status_code in (200, 204)
                again = api.post("/api/missions", json=body)
                assert again.status_code == 201, again.text
                api.post(f"/api/missions/{again.json()['id']}/stop")
        finally:
            live.stop()
