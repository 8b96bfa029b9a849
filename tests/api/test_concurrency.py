"""Concurrent requests cannot get past a limit or duplicate work: a live-mission place is
taken before the first await, and concurrent resumes of one interrupted mission share one
rebuild."""

from __future__ import annotations

import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import httpx
import pytest

from app.services import replay
from engine import Mission
from tests.api.conftest import LiveServer, make_settings, wait_for


def _at_once(
    server: LiveServer, n: int, call: Callable[[httpx.Client], httpx.Response]
) -> list[httpx.Response]:
    """`n` requests released together, each on its own connection."""
    barrier = threading.Barrier(n)

    def one(_: int) -> httpx.Response:
        with server.client() as api:
            barrier.wait(timeout=30)
            return call(api)

    with ThreadPoolExecutor(n) as pool:
        return list(pool.map(one, range(n)))


def test_concurrent_creations_stop_at_the_live_mission_limit(tmp_path: Path) -> None:
    server = LiveServer(make_settings(tmp_path, max_running_missions=8, rate_limit_per_s=0))
    server.start()
    try:
        answers = _at_once(server, 40, lambda api: api.post("/api/missions", json={"paused": True}))
        codes = sorted(r.status_code for r in answers)
        assert codes == [201] * 8 + [429] * 32, codes
        refused = next(r for r in answers if r.status_code == 429)
        assert "REGOLITH_MAX_RUNNING_MISSIONS" in refused.json()["detail"]
        with server.client() as api:
            assert api.get("/api/health").json()["missions_live"] == 8
            assert api.get("/api/missions").json()["total"] == 8
            mid = next(r.json()["id"] for r in answers if r.status_code == 201)
            api.post(f"/api/missions/{mid}/stop").raise_for_status()
            assert api.post("/api/missions", json={"paused": True}).status_code == 201
    finally:
        server.stop()


def test_concurrent_resumes_of_an_interrupted_mission_build_one_engine(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    server = LiveServer(make_settings(tmp_path, rate_limit_per_s=0)).start()
    try:
        with server.client() as api:
            mid = api.post("/api/missions", json={"seed": 5, "speed": 300}).json()["id"]
            base = f"/api/missions/{mid}"
            wait_for(lambda: api.get(base).json()["sim_time"] > 200)
        server.restart()

        built: list[Mission] = []

        class Counted(Mission):
            def __init__(self, *args: Any, **kwargs: Any) -> None:
                super().__init__(*args, **kwargs)
                built.append(self)

        monkeypatch.setattr(replay, "Mission", Counted)
        answers = _at_once(server, 10, lambda api: api.post(f"{base}/resume"))
        assert [r.status_code for r in answers] == [200] * 10, [r.text for r in answers]
        assert {r.json()["status"] for r in answers} == {"running"}
        assert len(built) == 1
        with server.client() as api:
            assert api.get("/api/health").json()["missions_live"] == 1
            kinds = [a["kind"] for a in api.get(f"{base}/actions").json()]
            assert kinds == ["resume"]
            api.post(f"{base}/stop").raise_for_status()
            assert api.get(base).json()["status"] == "stopped"
            again = api.post(f"{base}/resume")
            assert again.status_code == 409 and "stopped" in again.json()["detail"]
    finally:
        server.stop()
