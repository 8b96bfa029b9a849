"""Operators need the token for every mutating call; viewers need none."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from app.security import TOKEN_FILE, load_or_create_token, resolve_token, token_matches
from app.settings import Settings
from tests.api.conftest import LiveServer, make_settings

pytestmark = pytest.mark.sqlite_only  # the token checks touch no database: run them once

MUTATIONS = [
    ("POST", "/api/missions", {"seed": 1}),
    ("POST", "/api/missions/1/pause", None),
    ("POST", "/api/missions/1/resume", None),
    ("POST", "/api/missions/1/stop", None),
    ("PUT", "/api/missions/1/speed", {"speed": 10}),
    ("PUT", "/api/missions/1/policy", {"policy": "nearest"}),
    ("POST", "/api/missions/1/robots", {"type": "hauler"}),
    ("POST", "/api/missions/1/robots/hauler-1/disable", {"mode": "abrupt"}),
    ("POST", "/api/missions/1/robots/hauler-1/enable", None),
    ("POST", "/api/missions/1/tasks", {"type": "excavate", "location": [10, 10]}),
]


@pytest.fixture(scope="module")
def shared(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    server = LiveServer(make_settings(tmp_path_factory.mktemp("auth"))).start()
    yield server
    server.stop()


@pytest.mark.parametrize(("method", "path", "body"), MUTATIONS)
def test_mutating_call_without_token_is_401_and_wrong_token_403(
    shared: LiveServer, method: str, path: str, body: object
) -> None:
    with shared.client(token=False) as anon:
        r = anon.request(method, path, json=body)
        assert r.status_code == 401, r.text
        assert r.headers["www-authenticate"] == "Bearer"
        r = anon.request(method, path, json=body, headers={"Authorization": "Bearer nope" * 3})
        assert r.status_code == 403, r.text
        r = anon.request(method, path, json=body, headers={"Authorization": "Basic abc"})
        assert r.status_code == 401, r.text


def test_reads_need_no_token(shared: LiveServer) -> None:
    with shared.client(token=False) as anon:
        for path in ("/api/health", "/api/missions", "/api/scenarios/reference", "/openapi.json"):
            assert anon.get(path).status_code == 200, path


def test_token_is_generated_once_and_kept(tmp_path: Path) -> None:
    settings = Settings(data_dir=tmp_path / "data")
    token = resolve_token(settings)
    assert len(token) >= 32
    assert (tmp_path / "data" / TOKEN_FILE).stat().st_mode & 0o077 == 0
    assert load_or_create_token(tmp_path / "data") == token
    assert token_matches(token, token) and not token_matches(token, token + "x")


def test_generated_token_guards_the_server(tmp_path: Path) -> None:
    server = LiveServer(Settings(data_dir=tmp_path)).start()
    try:
        token = (tmp_path / TOKEN_FILE).read_text().strip()
        body = {"paused": True, "planner": "straight"}
        with httpx.Client(base_url=server.url) as anon:
            assert anon.post("/api/missions", json=body).status_code == 401
            ok = anon.post("/api/missions", json=body, headers={"Authorization": f"Bearer {token}"})
            assert ok.status_code == 201
    finally:
        server.stop()


def test_placeholder_token_is_refused() -> None:
    with pytest.raises(ValueError, match="REGOLITH_TOKEN"):
        Settings(token="changeme")
