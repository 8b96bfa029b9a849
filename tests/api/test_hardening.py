"""Limits and guards: rate limiting, body size, CORS, security headers, metrics."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

import pytest
from websockets.exceptions import ConnectionClosed

from tests.api.conftest import LiveServer, make_settings, recv


@pytest.fixture
def strict(tmp_path: Path) -> Iterator[LiveServer]:
    settings = make_settings(
        tmp_path,
        rate_limit_per_s=1,
        rate_limit_burst=3,
        max_running_missions=1,
        cors_origins=["https://ops.example"],
    )
    server = LiveServer(settings).start()
    yield server
    server.stop()


def test_mutating_calls_are_rate_limited_per_client(strict: LiveServer) -> None:
    with strict.client() as api:
        codes = [api.post("/api/missions/1/pause").status_code for _ in range(5)]
        assert codes[:3] == [404, 404, 404] and codes[3:] == [429, 429]
        r = api.post("/api/missions/1/pause")
        assert "retry" in r.json()["detail"] and int(r.headers["retry-after"]) >= 1
        assert api.get("/api/missions").status_code == 200  # reads are not limited


def test_live_mission_limit_is_429(strict: LiveServer) -> None:
    with strict.client() as api:
        assert api.post("/api/missions", json={"paused": True}).status_code == 201
        r = api.post("/api/missions", json={"paused": True})
        assert r.status_code == 429 and "already live" in r.json()["detail"]


def test_oversize_body_is_413(server: LiveServer) -> None:
    with server.client() as api:
        r = api.post("/api/missions", content=b"{" + b" " * 2_000_000 + b"}")
        assert r.status_code == 413

        def chunks() -> Iterator[bytes]:
            yield b'{"seed": 1, "x": "'
            for _ in range(300):
                yield b"a" * 4096
            yield b'"}'

        headers = {"content-type": "application/json"}
        assert api.post("/api/missions", content=chunks(), headers=headers).status_code == 413


def test_cors_only_for_configured_origins(strict: LiveServer) -> None:
    with strict.client(token=False) as anon:
        ok = anon.get("/api/health", headers={"Origin": "https://ops.example"})
        assert ok.headers["access-control-allow-origin"] == "https://ops.example"
        other = anon.get("/api/health", headers={"Origin": "https://evil.example"})
        assert "access-control-allow-origin" not in other.headers


def test_no_cors_by_default_and_security_headers(server: LiveServer) -> None:
    with server.client(token=False) as anon:
        r = anon.get("/api/health", headers={"Origin": "https://evil.example"})
        assert "access-control-allow-origin" not in r.headers
        assert r.headers["x-frame-options"] == "DENY"
        assert "default-src 'self'" in r.headers["content-security-policy"]
        docs = anon.get("/docs")  # Swagger UI comes from a CDN: no CSP there
        assert docs.status_code == 200 and "content-security-policy" not in docs.headers


def test_metrics_in_prometheus_format(server: LiveServer) -> None:
    with server.client() as api:
        api.post("/api/missions", json={"paused": True, "planner": "straight"})
        text = api.get("/api/metrics").text
    assert "# TYPE regolith_missions_live gauge" in text
    assert 'regolith_missions_live{status="paused"} 1' in text
    assert 'regolith_mission_speed{mission="1"} 1.0' in text
    assert "regolith_db_writes_total" in text and "regolith_frame_delay_seconds" in text


def test_viewer_limit_closes_extra_viewers_with_1013(tmp_path: Path) -> None:
    server = LiveServer(make_settings(tmp_path, max_viewers=1)).start()
    try:
        with server.client() as api:
            mid = api.post("/api/missions", json={"paused": True, "planner": "straight"}).json()
        with server.ws(mid["id"]) as first:
            assert recv(first)["type"] == "snapshot"
            with server.ws(mid["id"]) as second, pytest.raises(ConnectionClosed) as closed:
                recv(second)
            assert closed.value.rcvd is not None and closed.value.rcvd.code == 1013
    finally:
        server.stop()


def test_token_in_a_socket_url_never_reaches_the_logs() -> None:
    from app.logs import RedactTokens

    record = logging.LogRecord(
        "uvicorn.error",
        logging.INFO,
        __file__,
        1,
        '%s - "WebSocket %s" [accepted]',
        ("127.0.0.1:5", "/api/missions/1/live?token=s3cret-value&x=1"),
        None,
    )
    assert RedactTokens().filter(record)
    assert "s3cret" not in record.getMessage() and "token=***&x=1" in record.getMessage()
