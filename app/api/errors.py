"""One JSON error shape: `detail` (FastAPI's), plus `message` naming the field for 422s."""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from starlette.exceptions import HTTPException

from app.services.errors import Invalid, ServiceError
from engine import CommandRejected, ScenarioError, UnknownRobotError


def _where(loc: Any) -> str:
    return ".".join(str(p) for p in loc) or "request"


def _is_json(content_type: str) -> bool:
    media = content_type.split(";", 1)[0].strip().lower()
    return media == "application/json" or (
        media.startswith("application/") and media.endswith("+json")
    )


def _field_path(loc: Any, body: Any) -> tuple[Any, ...]:
    """The error's location with pydantic's union-member tags left out.

    A field that takes two types (`speed`: a number or "max") fails once per member, each
    located under the member's tag (`body.speed.constrained-float`, `body.speed.literal['max']`):
    validator names, not fields. So the location is walked through the request's own body:
    a key or index found there is a field, and so is the last part (a missing field); any
    other part is a tag. Query and path parameters keep their name only. An error a route
    raises itself (no body attached) is located already and kept as it is."""
    loc = tuple(loc)
    if body is None:  # raised by a route of its own (a scenario file's), located already
        return loc
    if not loc or loc[0] != "body":
        return tuple(p for i, p in enumerate(loc) if i < 2 or isinstance(p, int))
    out: list[Any] = [loc[0]]
    node = body
    for i, part in enumerate(loc[1:], start=1):
        in_dict = isinstance(node, dict) and isinstance(part, str)
        in_list = isinstance(node, list) and isinstance(part, int)
        if (in_dict and part in node) or (in_list and 0 <= part < len(node)):
            node = node[part]
        elif i == len(loc) - 1 and (in_dict or in_list):
            pass  # a missing field or item
        else:
            continue  # a union member's tag
        out.append(part)
    return tuple(out)


def _merged(errors: list[dict[str, Any]], unions: set[str]) -> list[tuple[str, str]]:
    """(field, message): a union's failures (fields in `unions`) once, joined with "or"
    ("Input should be greater than or equal to 0, or 'max'"); any other error as it is."""
    by_field: dict[str, list[dict[str, Any]]] = {}
    out = []
    for e in errors:
        if _where(e["loc"]) in unions:
            by_field.setdefault(_where(e["loc"]), []).append(e)
        else:
            out.append((_where(e["loc"]), e["msg"]))
    for where, group in by_field.items():
        # a check of our own (a ValueError) already says what the field takes: it alone
        own = [e["msg"].removeprefix("Value error, ") for e in group if e["type"] == "value_error"]
        msgs = list(dict.fromkeys(own or [e["msg"] for e in group]))
        rest = [m.removeprefix("Input should be ") for m in msgs[1:]]
        out.append((where, ", or ".join([msgs[0], *rest])))
    return out


async def _validation(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, RequestValidationError)
    errors = jsonable_encoder(exc.errors(), exclude={"input", "ctx", "url"})
    sent = request.headers.get("content-type", "")
    if not _is_json(sent):
        # FastAPI reads a body of another type as form data or not at all, then says only
        # "Input should be a valid dictionary": say what to send instead
        why = f"send JSON with Content-Type: application/json (this request's: {sent or 'none'})"
        for e in errors:
            if tuple(e["loc"]) == ("body",):
                e["msg"] = why
    body = getattr(exc, "body", None)
    unions = set()
    for e in errors:
        path = list(_field_path(e["loc"], body))
        if path != list(e["loc"]):
            unions.add(_where(path))
        e["loc"] = path
    message = "; ".join(f"{where}: {msg}" for where, msg in _merged(errors, unions))
    return JSONResponse({"detail": errors, "message": message}, status_code=422)


def _invalid(loc: tuple[Any, ...], message: str) -> JSONResponse:
    """A 422 shaped like FastAPI's, its message prefixed with the full field path."""
    loc = loc or ("body",)
    own = f"{loc[-1]}: "
    msg = message[len(own) :] if message.startswith(own) else message
    detail = [{"loc": list(loc), "msg": msg, "type": "value_error"}]
    return JSONResponse({"detail": detail, "message": f"{_where(loc)}: {msg}"}, status_code=422)


async def _service(_: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, ServiceError)
    if isinstance(exc, Invalid):
        return _invalid(exc.loc, exc.message)
    return JSONResponse({"detail": exc.message}, status_code=exc.status_code)


async def _engine(_: Request, exc: Exception) -> JSONResponse:
    if isinstance(exc, ScenarioError):
        return _invalid(("body", "scenario"), str(exc))
    code = 404 if isinstance(exc, UnknownRobotError) else 409
    return JSONResponse({"detail": str(exc)}, status_code=code)


_UNREADABLE: dict[type[BaseException], str] = {
    UnicodeError: "not valid UTF-8 JSON",
    RecursionError: "JSON nested too deeply",
}


async def _http(request: Request, exc: Exception) -> Response:
    """FastAPI answers a JSON body it cannot even decode (invalid UTF-8, nesting past the
    parser's depth) with a bare 400 that no route declares; it is bad input like any
    malformed JSON, so it gets the same documented 422 naming `body`."""
    assert isinstance(exc, HTTPException)
    cause = exc.__cause__
    if exc.status_code == 400 and cause is not None:
        for kind, text in _UNREADABLE.items():
            if isinstance(cause, kind):
                return _invalid(("body",), text)
    return await http_exception_handler(request, exc)


def install(app: FastAPI) -> None:
    app.add_exception_handler(RequestValidationError, _validation)
    app.add_exception_handler(HTTPException, _http)
    app.add_exception_handler(ServiceError, _service)
    for exc in (UnknownRobotError, CommandRejected, ScenarioError):
        app.add_exception_handler(exc, _engine)
