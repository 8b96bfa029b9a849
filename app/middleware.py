"""Small pure-ASGI middlewares (no per-request task overhead): request context and access
log, body size, security headers, NUL characters."""

from __future__ import annotations

import logging
import re
import uuid
from time import perf_counter
from urllib.parse import parse_qsl

from starlette.datastructures import MutableHeaders
from starlette.exceptions import HTTPException
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app import logs

access_log = logging.getLogger("regolith.access")
# An incoming X-Request-ID is kept only if it is short and plain (it ends up in every line).
_REQUEST_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._:/+=@-]{0,127}")
_MISSION = re.compile(r"/api/missions/(\d{1,10})(?:/|$)")

_HEADERS = {
    "x-content-type-options": "nosniff",
    "x-frame-options": "DENY",
    "referrer-policy": "no-referrer",
}
_CSP = (
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data:; connect-src 'self' ws: wss:; frame-ancestors 'none'"
)


class SecurityHeadersMiddleware:
    """Conservative headers on every HTTP answer (the dashboard is same-origin only)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                for k, v in _HEADERS.items():
                    headers.setdefault(k, v)
                # /docs and /redoc set their own (app/api/docs.py): they need an inline script
                headers.setdefault("content-security-policy", _CSP)
            await send(message)

        await self.app(scope, receive, send_with_headers)


class RejectNulMiddleware:
    """A query parameter or path with a NUL character is a 422 naming it: SQLite stores the
    text, but PostgreSQL refuses it, and that must not surface as a 500 (nor differ by
    database)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        where = _nul_in(scope) if scope["type"] == "http" else None
        if where is None:
            await self.app(scope, receive, send)
            return
        msg = "must not contain a NUL character"
        detail = [{"loc": list(where), "msg": msg, "type": "value_error"}]
        body = {"detail": detail, "message": f"{'.'.join(where)}: {msg}"}
        await JSONResponse(body, status_code=422)(scope, receive, send)


def _nul_in(scope: Scope) -> tuple[str, ...] | None:
    if "\x00" in scope["path"]:
        return ("path",)
    query = scope.get("query_string", b"").decode("latin-1")
    for key, value in parse_qsl(query, keep_blank_values=True):
        if "\x00" in key or "\x00" in value:
            return ("query", key.replace("\x00", "\\x00"))
    return None


class LimitBodyMiddleware:
    """Refuse request bodies over `max_bytes` with 413 before anything parses them."""

    def __init__(self, app: ASGIApp, max_bytes: int) -> None:
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        for name, value in scope.get("headers", []):
            if name == b"content-length" and (not value.isdigit() or int(value) > self.max_bytes):
                await JSONResponse({"detail": "request body too large"}, 413)(scope, receive, send)
                return
        seen = 0

        async def counted() -> Message:
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > self.max_bytes:  # a chunked body without Content-Length
                    raise HTTPException(413, "request body too large")
            return message

        await self.app(scope, counted, send)


def request_id_of(scope: Scope) -> str:
    """The client's X-Request-ID if it is sane, else a fresh one."""
    for name, value in scope.get("headers", []):
        if name == b"x-request-id":
            given: str = value.decode("latin-1")
            if _REQUEST_ID.fullmatch(given):
                return given
            break
    return uuid.uuid4().hex


def mission_of(path: str) -> int | None:
    """The mission id of a path under /api/missions/{id}."""
    match = _MISSION.match(path)
    if match is None:
        return None
    value = int(match.group(1))
    return value if value < 2**31 else None


class RequestContextMiddleware:
    """A request id (echoed as `X-Request-ID`) and the mission id in context for every log
    line of a request or WebSocket, then one access line: method, path (never the query,
    never headers), status or close code, duration."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        rid = request_id_of(scope)
        header = (b"x-request-id", rid.encode("latin-1"))
        context = logs.bind(rid, mission_of(scope["path"]))
        start = perf_counter()
        seen: dict[str, int | None] = {"status": None, "close_code": None}

        async def send_with_id(message: Message) -> None:
            kind = message["type"]
            if kind in ("http.response.start", "websocket.accept"):
                seen["status"] = message.get("status", 101)
                message = {**message, "headers": [*message.get("headers", []), header]}
            elif kind == "websocket.close":
                seen["close_code"] = message.get("code", 1000)
            await send(message)

        async def receive_ws() -> Message:
            message = await receive()
            if message["type"] == "websocket.disconnect" and seen["close_code"] is None:
                seen["close_code"] = message.get("code", 1005)
            return message

        try:
            await self.app(
                scope, receive_ws if scope["type"] == "websocket" else receive, send_with_id
            )
        except Exception:
            seen["status"] = seen["status"] or 500
            raise
        finally:
            _access(scope, seen["status"], seen["close_code"], perf_counter() - start)
            logs.unbind(context)


def _access(scope: Scope, status: int | None, close_code: int | None, seconds: float) -> None:
    ms = round(seconds * 1000, 1)
    client = str(scope["client"][0]) if scope.get("client") else None
    path = scope["path"]
    if scope["type"] == "websocket":
        access_log.info(
            "WebSocket %s closed %s after %.1f s",
            path,
            close_code,
            seconds,
            extra={
                "method": "WS",
                "path": path,
                "status": status,
                "close_code": close_code,
                "duration_ms": ms,
                "client": client,
            },
        )
        return
    # no status: the client went away before an answer was started
    level = logging.WARNING if status is None else logging.ERROR if status >= 500 else logging.INFO
    method = scope["method"]
    access_log.log(
        level,
        "%s %s %s %.1f ms",
        method,
        path,
        status,
        ms,
        extra={
            "method": method,
            "path": path,
            "status": status,
            "duration_ms": ms,
            "client": client,
        },
    )
