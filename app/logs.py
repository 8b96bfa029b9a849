"""Service logging: one JSON object (or one text line) per record, with request and mission ids.

Nothing here runs at import time: `regolith serve` calls `configure()` once, and the
lifespan only adds the token filter to the loggers whose handlers someone else owns (an
embedding application, uvicorn's default config in tests). The request id and mission id
travel in context variables set by `app.middleware.RequestContextMiddleware`, so every
line logged while a request runs carries them; the runner passes `mission_id` explicitly.
"""

from __future__ import annotations

import json
import logging
import re
import sys
from contextvars import ContextVar, Token
from datetime import UTC, datetime
from typing import Any, Literal, TextIO
from urllib.parse import unquote_plus

LogFormat = Literal["json", "text"]

request_id: ContextVar[str | None] = ContextVar("regolith_request_id", default=None)
mission_id: ContextVar[int | None] = ContextVar("regolith_mission_id", default=None)

# `Bearer …`/`Basic …` in an Authorization header (uvicorn logs raw ASGI scopes, headers
# included, at --log-level trace; the websockets library logs handshake headers at debug).
_SCHEMES = re.compile(r"(bearer\s+|basic\s+)[^&\s\"'\\,)]+", re.IGNORECASE)
# Any `key=value` of a query string: the key is judged once percent-decoded (`?tok%65n=` is
# `token` to the server), so no spelling of it slips through.
_PAIRS = re.compile(r"(?P<key>[^\s?&=\"'\\,()\[\]{}<>]+)=(?P<value>[^&\s\"'\\,)]*)")
# A browser can only send a socket's credentials as a subprotocol, so that header's values are
# never logged in any form: a handshake line, an ASGI header pair, the scope's subprotocols.
_SUBPROTOCOL = re.compile(
    r"(sec-websocket-protocol:\s*)[^\r\n\"'\\]*"
    r"|(sec-websocket-protocol['\"]?\s*,\s*b?['\"])[^'\"]*"
    r"|(['\"]subprotocols?['\"]\s*:\s*)(?:\[[^\]]*\]|b?'[^']*'|b?\"[^\"]*\")",
    re.IGNORECASE,
)
_LOGGERS = ("uvicorn.error", "uvicorn.access", "uvicorn.asgi", "regolith")
#: Fields an access line (or any record given them as `extra`) adds to the JSON object.
_FIELDS = (
    "request_id",
    "mission_id",
    "method",
    "path",
    "status",
    "close_code",
    "duration_ms",
    "client",
)


def _secret_key(key: str) -> bool:
    """A query key that names a token once fully percent-decoded (`tok%2565n` too)."""
    for _ in range(4):
        decoded = unquote_plus(key)
        if decoded == key:
            break
        key = decoded
    return "token" in key.lower()


def _pair(match: re.Match[str]) -> str:
    if _secret_key(match["key"]):
        return f"{match['key']}=***"
    return match[0]


def _subprotocol(match: re.Match[str]) -> str:
    return f"{match[1] or match[2] or match[3]}***"


def redact(text: str) -> str:
    """`text` with every token value replaced by `***`."""
    text = _SUBPROTOCOL.sub(_subprotocol, text)
    return _SCHEMES.sub(r"\1***", _PAIRS.sub(_pair, text))


class RedactTokens(logging.Filter):
    """Rewrite token values in a record's message as `***`."""

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        clean = redact(message)
        if clean != message:
            record.msg, record.args = clean, None
        return True


class ContextFilter(logging.Filter):
    """Copy the current request id and mission id onto the record (explicit extras win)."""

    def filter(self, record: logging.LogRecord) -> bool:
        if getattr(record, "request_id", None) is None:
            record.request_id = request_id.get()
        if getattr(record, "mission_id", None) is None:
            record.mission_id = mission_id.get()
        return True


def _uvicorn_access(record: logging.LogRecord, out: dict[str, Any]) -> None:
    """uvicorn's own access line (if someone turns it on) as fields, not just text."""
    args = record.args
    if record.name == "uvicorn.access" and isinstance(args, tuple) and len(args) == 5:
        client, method, path, _, status = args
        out.update(client=str(client), method=method, path=redact(str(path)), status=status)


class JsonFormatter(logging.Formatter):
    """ts, level, logger, msg, then the request/mission/access fields that are known."""

    def format(self, record: logging.LogRecord) -> str:
        ts = datetime.fromtimestamp(record.created, UTC).isoformat(timespec="milliseconds")
        out: dict[str, Any] = {
            "ts": ts.replace("+00:00", "Z"),
            "level": record.levelname,
            "logger": record.name,
            "msg": record.getMessage(),
        }
        for key in _FIELDS:
            value = getattr(record, key, None)
            if value is not None:
                out[key] = value
        _uvicorn_access(record, out)
        if record.exc_info:
            out["exc"] = self.formatException(record.exc_info)
        return redact(json.dumps(out, default=str, ensure_ascii=False))


class TextFormatter(logging.Formatter):
    """A line for a human at a terminal: time, level, logger, [ids], message."""

    def __init__(self) -> None:
        super().__init__("%(asctime)s %(levelname)-7s %(name)s %(ids)s%(message)s")

    def format(self, record: logging.LogRecord) -> str:
        req, mission = getattr(record, "request_id", None), getattr(record, "mission_id", None)
        ids = [f"req={req}"] if req else []
        if mission is not None:
            ids.append(f"mission={mission}")
        record.ids = f"[{' '.join(ids)}] " if ids else ""
        return redact(super().format(record))


class _Handler(logging.StreamHandler[TextIO]):
    """Marks the handler `configure` installed, so calling it again replaces, not adds."""


def configure(
    fmt: LogFormat = "json", level: int | str = logging.INFO, stream: TextIO | None = None
) -> logging.Handler:
    """Send the `regolith` and `uvicorn` loggers to one handler in `fmt` (idempotent)."""
    handler = _Handler(stream if stream is not None else sys.stderr)
    handler.setFormatter(JsonFormatter() if fmt == "json" else TextFormatter())
    handler.addFilter(ContextFilter())
    handler.addFilter(RedactTokens())
    for name in ("regolith", "uvicorn"):
        logger = logging.getLogger(name)
        for old in [h for h in logger.handlers if isinstance(h, _Handler)]:
            logger.removeHandler(old)
        logger.addHandler(handler)
        logger.propagate = False
    logging.getLogger("regolith").setLevel(level)
    return handler


def default_format(stream: TextIO | None = None) -> LogFormat:
    """Text for a person at a terminal, JSON for anything that collects logs."""
    stream = stream if stream is not None else sys.stderr
    return "text" if stream.isatty() else "json"


def bind(req: str | None, mission: int | None) -> tuple[Token[str | None], Token[int | None]]:
    """Set the ids for the current context; pass the result to `unbind`."""
    return request_id.set(req), mission_id.set(mission)


def unbind(tokens: tuple[Token[str | None], Token[int | None]]) -> None:
    request_id.reset(tokens[0])
    mission_id.reset(tokens[1])


def install() -> RedactTokens:
    """Redact tokens on the loggers themselves (covers handlers `configure` did not add)."""
    redact_filter = RedactTokens()
    for name in _LOGGERS:
        logging.getLogger(name).addFilter(redact_filter)
    return redact_filter


def uninstall(redact_filter: RedactTokens) -> None:
    for name in _LOGGERS:
        logging.getLogger(name).removeFilter(redact_filter)
