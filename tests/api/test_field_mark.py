"""A stored mission says whether it was simulated or a field run, and nothing that re-simulates
(resume after a restart, playback) treats a field run as a simulation: resume refuses it,
playback reads it from the database (app/services/field_playback.py) instead of replaying it.

A real field mission is twelve agent processes over Zenoh (tests/field, marked `fleet`, slow);
here the one thing they change — what `_build_field` hands the runner — is an engine mission
instead, so everything the service stores and refuses is the real code path, in seconds.
"""

from __future__ import annotations

import random
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import httpx
import pytest
from sqlalchemy import text

from app.db.session import make_engine
from app.services.missions import MissionService
from tests.api.conftest import LiveServer, all_pages, make_settings, wait_for


@pytest.fixture
def stand_in_field(monkeypatch: pytest.MonkeyPatch) -> None:
    """Field missions built as engine missions (no agent processes); stored as field runs."""

    def build(
        self: MissionService, scenario: Any, seed: int, policy: str, speed: Any, paused: bool
    ) -> Any:
        return self._build(scenario, seed, policy, "exact")

    monkeypatch.setattr(MissionService, "_build_field", build)


def _records(api: httpx.Client, mid: int) -> tuple[Any, ...]:
    """Everything stored of a mission: its record, actions, auctions and whole event log."""
    base = f"/api/missions/{mid}"
    events: list[dict[str, Any]] = []
    while True:
        page = api.get(f"{base}/events", params={"after": len(events) - 1, "limit": 1000}).json()
        events += page["items"]
        if page["next_after"] is None:
            break
    return api.get(base).json(), all_pages(api, f"{base}/auctions"), events


def _db_modes(settings: Any) -> dict[int, str]:
    engine = make_engine(settings.database_url)
    try:
        with engine.connect() as db:
            return {i: m for i, m in db.execute(text("select id, mode from missions"))}
    finally:
        engine.dispose()


def test_interrupted_field_mission_is_kept_and_not_resumed(
    tmp_path: Path, stand_in_field: None
) -> None:
    """A field mission live when the server stops comes back `interrupted`; its resume is a
    409 that says why, however often and concurrently asked, and leaves every record as
    stored; playback answers it from what was stored, live and after the restart, and changes
    nothing. A simulated twin (same seed) resumes and plays back."""
    rng = random.Random()
    seed = rng.randrange(1000)
    policy = rng.choice(["fcfs", "nearest", "coalition"])
    speed = rng.choice([100, 200, 300])
    server = LiveServer(make_settings(tmp_path)).start()
    try:
        with server.client() as api:
            field = api.post(
                "/api/missions",
                json={"seed": seed, "policy": policy, "speed": speed, "field": True},
            )
            assert field.status_code == 201, field.text
            fid = field.json()["id"]
            sim = api.post("/api/missions", json={"seed": seed, "policy": policy, "speed": speed})
            sid = sim.json()["id"]
            assert field.json()["mode"] == "field" and sim.json()["mode"] == "simulated"
            fbase = f"/api/missions/{fid}"
            wait_for(lambda: api.get(fbase).json()["sim_time"] > rng.uniform(50, 250))
            if rng.random() < 0.5:  # an operator action recorded on the field run
                other = "nearest" if policy != "nearest" else "fcfs"
                api.put(f"{fbase}/policy", json={"policy": other}).raise_for_status()
            live_playback = api.get(f"{fbase}/state", params={"t": 1})
            assert live_playback.status_code == 200, live_playback.text
            assert live_playback.json()["mission"]["mode"] == "field"
            assert live_playback.json()["state"]["t"] == 1

        server.restart()

        assert _db_modes(server.settings) == {fid: "field", sid: "simulated"}
        with server.client() as api:
            before = _records(api, fid)
            assert before[0]["status"] == "interrupted" and before[0]["mode"] == "field"
            assert before[2], "the field run stored events"
            attempts = rng.randint(1, 4)
            with ThreadPoolExecutor(attempts) as pool:
                answers = list(pool.map(lambda _: api.post(f"{fbase}/resume"), range(attempts)))
            for r in answers:
                assert r.status_code == 409, r.text
                message = r.json()["detail"]
                assert f"mission {fid} is a field mission" in message
                assert "start a new field mission" in message
            stored = api.get(f"{fbase}/state", params={"t": before[0]["sim_time"]})
            assert stored.status_code == 200, stored.text
            # (the stand-in is an engine: it reports no poses, so no robot is drawn)
            assert stored.json()["state"]["robots"] == []
            found = sum(1 for e in before[2] if e["kind"] == "site_found")
            assert stored.json()["state"]["counters"]["sites_found"] == found
            assert _records(api, fid) == before

            resumed = api.post(f"/api/missions/{sid}/resume")
            assert resumed.status_code == 200 and resumed.json()["mode"] == "simulated"
            assert api.get(f"/api/missions/{sid}/state", params={"t": 1}).status_code == 200
            api.post(f"/api/missions/{sid}/stop").raise_for_status()

        server.restart()  # and the refusal holds on the next start as well

        with server.client() as api:
            assert api.post(f"{fbase}/resume").status_code == 409
            assert _records(api, fid) == before
    finally:
        server.stop()


def test_list_filters_by_mode(tmp_path: Path, stand_in_field: None) -> None:
    """`?mode=` keeps one kind of run (with the other filters), a bad value is a 422 naming
    `mode`, and every listed and read mission carries its mode."""
    rng = random.Random()
    server = LiveServer(make_settings(tmp_path)).start()
    try:
        with server.client() as api:
            modes: dict[int, str] = {}
            for _ in range(rng.randint(3, 5)):
                field = rng.random() < 0.5
                body: dict[str, Any] = {"seed": rng.randrange(100), "speed": 50}
                if field:
                    body["field"] = True
                else:
                    body["paused"] = True
                r = api.post("/api/missions", json=body)
                assert r.status_code == 201, r.text
                modes[r.json()["id"]] = "field" if field else "simulated"
            stopped = rng.sample(sorted(modes), k=rng.randint(1, len(modes)))
            for mid in stopped:
                api.post(f"/api/missions/{mid}/stop").raise_for_status()
            assert _db_modes(server.settings) == modes
            for mid, mode in modes.items():
                assert api.get(f"/api/missions/{mid}").json()["mode"] == mode

            def listed(**params: str) -> dict[int, str]:
                page = api.get("/api/missions", params=params).json()
                assert page["total"] == len(page["items"])
                return {m["id"]: m["mode"] for m in page["items"]}

            assert listed() == modes
            for mode in ("simulated", "field"):
                assert listed(mode=mode) == {i: m for i, m in modes.items() if m == mode}
                want = {i: m for i, m in modes.items() if m == mode and i in stopped}
                assert listed(mode=mode, status="stopped") == want
            bad = api.get("/api/missions", params={"mode": rng.choice(["Field", "sim", "1"])})
            assert bad.status_code == 422 and "mode" in bad.json()["message"], bad.text
    finally:
        server.stop()
