"""Limits and guards: rate limiting, body size, CORS, security headers, metrics, bad input."""

from __future__ import annotations

import http.client
import logging
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect

from app.cli.serve import KEEP_ALIVE_S
from tests.api.conftest import TOKEN, LiveServer, make_settings, recv
from tests.api.serve_process import ServeProcess
from tests.progress import REQUEST_S


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


@pytest.mark.parametrize(
    ("body", "says"),
    [
        (b'{"seed": "\xff\xfe"}', "not valid UTF-8 JSON"),
        (b"[" * 5000, "JSON nested too deeply"),  # past the parser's depth: RecursionError
        (b'{"a":' * 3000, "JSON nested too deeply"),
    ],
)
def test_undecodable_json_bodies_are_a_documented_422(
    server: LiveServer, body: bytes, says: str
) -> None:
    """These were a bare 400 (FastAPI's "error parsing the body"), in no route's schema."""
    headers = {"content-type": "application/json"}
    with server.client() as api:
        paths = api.get("/openapi.json").json()["paths"]
        for method, path, route in [
            ("POST", "/api/missions", "/api/missions"),
            ("PUT", "/api/missions/1/speed", "/api/missions/{mission_id}/speed"),
            ("POST", "/api/sweeps", "/api/sweeps"),
        ]:
            r = api.request(method, path, content=body, headers=headers)
            assert r.status_code == 422, (path, r.text)
            assert r.json()["message"] == f"body: {says}"
            assert "422" in paths[route][method.lower()]["responses"]
        assert api.get("/api/missions").json()["total"] == 0


def test_a_nul_in_a_query_parameter_is_a_422_naming_it_on_every_database(
    server: LiveServer,
) -> None:
    """PostgreSQL refuses NUL in text; schemathesis found the 500 it made through a filter."""
    with server.client() as api:
        mid = api.post("/api/missions", json={"paused": True}).json()["id"]
        for path, name in [
            (f"/api/missions/{mid}/events?kind=hello%00&kind=award", "kind"),
            (f"/api/missions/{mid}/auctions?robot=scout-1%00", "robot"),
        ]:
            r = api.get(path)
            assert r.status_code == 422, (path, r.text)
            assert r.json()["message"] == f"query.{name}: must not contain a NUL character"
        assert api.get(f"/api/missions/{mid}/events?kind=hello").status_code == 200
        assert api.get(f"/api/missions/{mid}").json()["id"] == mid  # nothing stored is lost


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
        for page in ("/docs", "/redoc"):  # served with their assets: this origin only
            docs = anon.get(page)
            csp = docs.headers["content-security-policy"]
            assert docs.status_code == 200 and "default-src 'self';" in csp, page
            assert "http" not in csp and "http" not in docs.text.replace(docs.url.host, ""), page


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


def _samples(text: str) -> dict[str, float]:
    """Prometheus text as {'name{labels}': value}."""
    out = {}
    for line in text.splitlines():
        if line and not line.startswith("#"):
            key, _, value = line.rpartition(" ")
            out[key] = float(value)
    return out


def test_metrics_cover_what_issue_7_asks_for(server: LiveServer) -> None:
    """Missions running, sim speed, viewers, frame delay, auctions, DB write latency."""
    with server.client() as api:
        # speed 100: 300 s of simulation in ~3 s, and ~20 s of margin before the mission ends
        # (at 500 a loaded machine could see it finish before the stop)
        body = {"seed": 2, "speed": 100, "paused": True, "planner": "straight"}
        mid = api.post("/api/missions", json=body).json()["id"]
        with server.ws(mid) as ws:
            recv(ws)
            api.post(f"/api/missions/{mid}/resume").raise_for_status()
            while recv(ws).get("t", 0) < 300:  # long enough for auctions to open
                pass
            m = _samples(api.get("/api/metrics").text)
        api.post(f"/api/missions/{mid}/stop").raise_for_status()
    one = f'{{mission="{mid}"}}'
    assert m['regolith_missions_live{status="running"}'] == 1
    assert m[f"regolith_mission_speed{one}"] == 100
    assert m[f"regolith_mission_sim_time_seconds{one}"] >= 300
    assert m[f"regolith_mission_auctions_total{one}"] > 0  # rate() of it: auctions per second
    assert m[f"regolith_viewers{one}"] == 1 and m[f"regolith_viewer_backlog{one}"] == 0
    p50, p99 = (m[f'regolith_frame_delay_seconds{{quantile="{q}"}}'] for q in ("0.5", "0.99"))
    assert 0 <= p50 <= p99 < 5
    assert m["regolith_frames_sent_total"] > 0
    assert m["regolith_db_writes_total"] > 0 and m["regolith_db_write_seconds_total"] > 0
    assert m["regolith_db_write_seconds_max"] > 0 and "regolith_db_write_queue" in m


@pytest.fixture
def small(tmp_path: Path) -> Iterator[LiveServer]:
    server = LiveServer(make_settings(tmp_path, max_robots=13, max_grid_cells=1000)).start()
    yield server
    server.stop()


def test_configured_size_limits_are_422_and_429(small: LiveServer) -> None:
    with small.client() as api:
        big = {"scenario": {"team": {"haulers": 10}}, "paused": True}
        r = api.post("/api/missions", json=big)
        assert r.status_code == 422 and "body.scenario.team" in r.json()["message"]
        assert "REGOLITH_MAX_ROBOTS" in r.json()["message"]
        wide = {"scenario": {"width": 200, "height": 200}, "paused": True}
        r = api.post("/api/missions", json=wide)
        assert r.status_code == 422 and "REGOLITH_MAX_GRID_CELLS" in r.json()["message"]
        mid = api.post("/api/missions", json={"paused": True, "planner": "straight"}).json()["id"]
        assert api.post(f"/api/missions/{mid}/robots", json={"type": "hauler"}).status_code == 201
        r = api.post(f"/api/missions/{mid}/robots", json={"type": "hauler"})
        assert r.status_code == 429 and "13 robots" in r.json()["detail"]


@pytest.mark.parametrize(
    ("scenario", "says"),
    [
        ({"timing": {"dig_s": -1}}, "body.scenario.timing.dig_s"),
        ({"protocol": {"bid_window_s": -0.5}}, "body.scenario.protocol.bid_window_s"),
        ({"max_time_s": 0}, "body.scenario.max_time_s"),
        ({"craters": [{"x": 50, "y": 50, "r": 5}]}, "craters[0] covers the plant"),
        ({"plant": [150, 50]}, "plant must lie inside the area"),
    ],
)
def test_scenarios_that_cannot_work_are_422_naming_the_reason(
    api: httpx.Client, scenario: dict[str, object], says: str
) -> None:
    r = api.post("/api/missions", json={"scenario": scenario})
    assert r.status_code == 422 and says in r.json()["message"], r.text


def _closed_with(ws: ClientConnection) -> int:
    with pytest.raises(ConnectionClosed) as closed:
        while True:  # frames may arrive before the close
            ws.recv(timeout=REQUEST_S)
    assert closed.value.rcvd is not None
    return closed.value.rcvd.code


@pytest.mark.parametrize(
    ("message", "code"),
    [
        ("x" * 5000, 1009),
        (b"\x00\x01", 1003),
        ("not json", 1003),
        ("y" * 100_000, 1009),
        ("[" * 4000, 1003),  # under the size limit, but deeper than the parser: RecursionError
        ("[" * 2000 + "]" * 2000, 1003),  # well-formed, just as deep
    ],
)
def test_bad_socket_input_closes_that_socket_on_a_real_server(
    server: LiveServer, api: httpx.Client, message: str | bytes, code: int
) -> None:
    mid = api.post("/api/missions", json={"paused": True, "planner": "straight"}).json()["id"]
    with server.ws(mid) as ws, server.ws(mid) as other:
        assert recv(ws)["type"] == "snapshot" and recv(other)["type"] == "snapshot"
        ws.send(message)
        assert _closed_with(ws) == code
        other.send("{}")  # the other viewer is untouched
        api.post(f"/api/missions/{mid}/resume").raise_for_status()
        assert recv(other)["type"] in ("frame", "status", "event", "auction")


@pytest.mark.parametrize("mission_id", [10**30, 2**31, 0])
def test_a_socket_for_an_impossible_mission_id_closes_with_1008(
    server: LiveServer, mission_id: int
) -> None:
    """10**30 once raised OverflowError in the database driver, unhandled."""
    with server.ws(mission_id) as ws, pytest.raises(ConnectionClosed) as closed:
        ws.recv(timeout=REQUEST_S)
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 1008
    assert "mission_id" in closed.value.rcvd.reason
    with server.ws(2**31 - 1) as ws:  # the largest id is merely unknown
        assert _closed_with(ws) == 4404


def test_socket_needs_the_token_when_reads_do(tmp_path: Path) -> None:
    server = LiveServer(make_settings(tmp_path, read_requires_token=True)).start()
    try:
        with server.client() as api:
            mid = api.post("/api/missions", json={"paused": True, "planner": "straight"}).json()
        with connect(f"ws://127.0.0.1:{server.port}/api/missions/{mid['id']}/live") as ws:
            assert _closed_with(ws) == 1008
        url = f"ws://127.0.0.1:{server.port}/api/missions/{mid['id']}/live?token={TOKEN}"
        with connect(url) as ws:
            assert recv(ws)["type"] == "snapshot"
        with server.client(token=False) as anon:
            assert anon.get("/api/missions").status_code == 401
    finally:
        server.stop()


@pytest.mark.sqlite_only
def test_an_idle_connection_is_left_for_the_client_to_close(tmp_path: Path) -> None:
    """`regolith serve` keeps an idle connection open past the 5 s after which clients such
    as httpx close their own: a server closing first races the client's next request, which
    then meets a reset connection (a poll of a field mission failed so in CI)."""
    idle_s = 6.0  # past uvicorn's default keep-alive and httpx's own expiry, both 5 s
    assert idle_s < KEEP_ALIVE_S
    with ServeProcess(tmp_path / "serve") as srv:
        conn = http.client.HTTPConnection("127.0.0.1", srv.port, timeout=REQUEST_S)
        try:
            conn.request("GET", "/api/health")
            assert conn.getresponse().read() and conn.sock is not None
            first = conn.sock
            time.sleep(idle_s)
            conn.request("GET", "/api/health")
            answer = conn.getresponse()
            assert answer.status == 200 and answer.read(), answer.status
            assert conn.sock is first  # the same connection, not a new one
        finally:
            conn.close()
