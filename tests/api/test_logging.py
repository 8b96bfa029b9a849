"""Structured logs: one JSON object per line with request and mission ids, never the token."""

from __future__ import annotations

import io
import json
import logging
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from app import logs
from app.cli import cli
from app.middleware import mission_of, request_id_of
from tests.api.conftest import TOKEN
from tests.api.serve_process import ServeProcess
from tests.progress import REQUEST_S

Line = dict[str, Any]


def _lines(text: str) -> list[Line]:
    """Every line must be one JSON object with the four base fields."""
    out = []
    for raw in text.splitlines():
        line = json.loads(raw)
        assert {"ts", "level", "logger", "msg"} <= set(line), raw
        assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", line["ts"]), raw
        out.append(line)
    return out


def _one(lines: list[Line], **match: Any) -> Line:
    found = [ln for ln in lines if all(ln.get(k) == v for k, v in match.items())]
    assert len(found) == 1, (match, found)
    return found[0]


@pytest.mark.sqlite_only  # the log lines, whatever the database
def test_serve_logs_json_lines_with_ids_and_never_the_token(tmp_path: Path) -> None:
    """The real command at its noisiest level (trace: uvicorn logs every ASGI message)."""
    wrong = "Bearer wrong-token-value-0123456789"
    env = {"REGOLITH_READ_REQUIRES_TOKEN": "true"}
    with (
        ServeProcess(tmp_path, "--log-format", "json", "--log-level", "trace", **env) as srv,
        srv.client() as api,
    ):
        r = api.post(
            "/api/missions",
            json={"paused": True, "planner": "straight"},
            headers={"X-Request-ID": "op-42"},
        )
        assert r.status_code == 201 and r.headers["x-request-id"] == "op-42"
        mid = r.json()["id"]
        r = api.get(f"/api/missions/{mid}", headers={"X-Request-ID": "no spaces allowed"})
        generated = r.headers["x-request-id"]
        assert re.fullmatch(r"[0-9a-f]{32}", generated)
        url = f"ws://127.0.0.1:{srv.port}/api/missions/{mid}/live?token={TOKEN}"
        with connect(url, additional_headers={"Authorization": f"Bearer {TOKEN}"}) as ws:
            assert json.loads(ws.recv(timeout=REQUEST_S))["type"] == "snapshot"
            assert ws.response is not None
            socket_rid = ws.response.headers["x-request-id"]
            ws.send("not json")
            with pytest.raises(ConnectionClosed) as closed:
                while True:  # a first frame may come before the close
                    ws.recv(timeout=REQUEST_S)
            assert closed.value.rcvd is not None and closed.value.rcvd.code == 1003
        r = api.post(f"/api/missions/{mid}/stop", headers={"X-Request-ID": "op-stop"})
        assert r.status_code == 200
        assert api.get("/api/missions", headers={"Authorization": wrong}).status_code == 403
    err, out = srv.stderr(), srv.stdout()
    assert TOKEN not in err and TOKEN not in out
    assert "wrong-token-value" not in err
    lines = _lines(err)
    assert any(ln["level"] == "TRACE" and "scope=" in ln["msg"] for ln in lines)  # the noisiest
    assert not [ln for ln in lines if ln["logger"] == "uvicorn.access"]  # ours replaces it

    created = _one(lines, logger="regolith.access", request_id="op-42")
    assert created["method"] == "POST" and created["path"] == "/api/missions"
    assert created["status"] == 201 and created["level"] == "INFO"
    assert isinstance(created["duration_ms"], float) and created["duration_ms"] >= 0
    assert created["msg"].startswith("POST /api/missions 201 ")
    live = _one(lines, logger="regolith.runner", request_id="op-42")
    assert live["mission_id"] == mid and "live" in live["msg"]

    read = _one(lines, logger="regolith.access", request_id=generated)
    assert read["mission_id"] == mid and read["path"] == f"/api/missions/{mid}"

    socket = _one(lines, logger="regolith.access", method="WS", request_id=socket_rid)
    assert socket["mission_id"] == mid and socket["close_code"] == 1003
    assert socket["path"] == f"/api/missions/{mid}/live"  # the query (and token) left out
    handshake = [ln for ln in lines if ln.get("request_id") == socket["request_id"]]
    accepted = [ln for ln in handshake if ln["msg"].endswith("[accepted]")]
    assert len(accepted) == 1 and "token=***" in accepted[0]["msg"]
    assert accepted[0]["mission_id"] == mid and accepted[0]["logger"] == "uvicorn.error"
    # at debug level the websockets library logs the handshake's request line and headers
    assert any(ln["msg"].lower() == "< authorization: bearer ***" for ln in lines)
    assert any(ln["msg"] == f"< GET /api/missions/{mid}/live?token=*** HTTP/1.1" for ln in lines)

    ended = _one(lines, logger="regolith.runner", request_id="op-stop")
    assert ended["mission_id"] == mid and ended["msg"].startswith(f"mission {mid} ended: stopped")
    refused = [ln for ln in lines if ln.get("status") == 403]
    assert len(refused) == 1 and refused[0]["path"] == "/api/missions"


def test_text_format_names_the_ids() -> None:
    record = logging.LogRecord("regolith.runner", logging.INFO, __file__, 1, "hi %s", ("x",), None)
    context = logs.bind("req-1", 7)
    try:
        assert logs.ContextFilter().filter(record)
    finally:
        logs.unbind(context)
    text = logs.TextFormatter().format(record)
    assert text.endswith(" INFO    regolith.runner [req=req-1 mission=7] hi x")
    line = json.loads(logs.JsonFormatter().format(record))
    assert line["request_id"] == "req-1" and line["mission_id"] == 7 and line["msg"] == "hi x"
    assert logs.request_id.get() is None and logs.mission_id.get() is None  # unbound again


def test_secrets_are_redacted_wherever_they_appear() -> None:
    raw = "[(b'authorization', b'Bearer abc.def-123'), ('q', '/live?token=s3cret&x=1')] basic Zm9v"
    assert logs.redact(raw) == (
        "[(b'authorization', b'Bearer ***'), ('q', '/live?token=***&x=1')] basic ***"
    )


def test_query_keys_are_judged_decoded_and_subprotocols_never_logged() -> None:
    assert logs.redact("< GET /live?tok%65n=s3cret HTTP/1.1") == "< GET /live?tok%65n=*** HTTP/1.1"
    assert logs.redact("/live?a=1&tok%2565n=s3cret&b=2") == "/live?a=1&tok%2565n=***&b=2"
    assert logs.redact("'query_string': b'%74OKEN=s3cret'") == "'query_string': b'%74OKEN=***'"
    assert logs.redact("level=x scope=y") == "level=x scope=y"  # other pairs are kept
    assert logs.redact("< Sec-WebSocket-Protocol: s3cret, v1") == "< Sec-WebSocket-Protocol: ***"
    assert logs.redact("[(b'sec-websocket-protocol', b's3cret'), (b'host', b'h')]") == (
        "[(b'sec-websocket-protocol', b'***'), (b'host', b'h')]"
    )
    assert logs.redact("{'subprotocols': ['s3cret'], 'x': 1}") == "{'subprotocols': ***, 'x': 1}"
    assert logs.redact("{'subprotocol': 's3cret'}") == "{'subprotocol': ***}"


@pytest.mark.sqlite_only  # the log lines, whatever the database
def test_serve_never_logs_an_encoded_query_token_or_a_subprotocol(tmp_path: Path) -> None:
    """`?tok%65n=` is `token` to the server and was logged whole; so was a token offered as a
    WebSocket subprotocol (the websockets library logs handshake headers at debug, uvicorn
    the ASGI scope and messages at trace)."""
    with (
        ServeProcess(tmp_path, "--log-format", "json", "--log-level", "trace") as srv,
        srv.client() as api,
    ):
        mid = api.post("/api/missions", json={"paused": True, "planner": "straight"}).json()["id"]
        base = f"ws://127.0.0.1:{srv.port}/api/missions/{mid}/live"
        for query in (f"?tok%65n={TOKEN}", f"?%74oken={TOKEN}", f"?a=1&tok%2565n={TOKEN}"):
            with connect(base + query) as ws:
                assert json.loads(ws.recv(timeout=REQUEST_S))["type"] == "snapshot"
        with connect(base, subprotocols=[TOKEN]) as ws:  # type: ignore[list-item]
            assert json.loads(ws.recv(timeout=REQUEST_S))["type"] == "snapshot"
    lines = _lines(srv.stderr())
    assert not [ln["msg"] for ln in lines if TOKEN in json.dumps(ln)]
    accepted = [ln["msg"] for ln in lines if ln["msg"].endswith("[accepted]")]
    assert len(accepted) == 4 and any("tok%65n=***" in msg for msg in accepted)
    assert any(ln["msg"].lower() == "< sec-websocket-protocol: ***" for ln in lines)


def test_request_id_is_kept_only_if_sane_and_mission_id_comes_from_the_path() -> None:
    def scope(value: bytes) -> dict[str, Any]:
        return {"headers": [(b"x-request-id", value)]}

    assert request_id_of(scope(b"abc-1.2:3/4")) == "abc-1.2:3/4"
    for bad in (b"a b", b"x" * 200, b"-leading", b"\xff", b""):
        assert re.fullmatch(r"[0-9a-f]{32}", request_id_of(scope(bad)))
    assert mission_of("/api/missions/12/live") == 12 and mission_of("/api/missions/12") == 12
    assert mission_of("/api/missions") is None and mission_of("/api/missions/12x") is None
    assert mission_of("/api/missions/99999999999") is None


@pytest.fixture
def clean_loggers() -> Iterator[None]:
    """`configure` changes process-wide loggers: put them back afterwards."""
    names = ("regolith", "uvicorn")
    saved = {
        n: (list(logging.getLogger(n).handlers), logging.getLogger(n).propagate) for n in names
    }
    level = logging.getLogger("regolith").level
    yield
    for n, (handlers, propagate) in saved.items():
        logging.getLogger(n).handlers[:] = handlers
        logging.getLogger(n).propagate = propagate
    logging.getLogger("regolith").setLevel(level)


@pytest.mark.usefixtures("clean_loggers")
def test_configure_twice_replaces_the_handler() -> None:
    first, second = io.StringIO(), io.StringIO()
    logs.configure("json", "INFO", first)
    logs.configure("text", "INFO", second)
    logging.getLogger("regolith.test").info("once with token=abc")
    logging.getLogger("uvicorn.error").warning("uvicorn too")
    assert first.getvalue() == ""
    assert second.getvalue().count("\n") == 2 and "token=***" in second.getvalue()
    assert logs.default_format(io.StringIO()) == "json"  # not a terminal


def test_unknown_log_format_is_a_usage_error() -> None:
    result = CliRunner().invoke(cli, ["serve", "--log-format", "xml"])
    assert result.exit_code == 2
    assert result.output.strip() == "regolith serve: --log-format xml: choose auto|json|text"
