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
    message = "; ".join(f"{_where(e['loc'])}: {e['msg']}" for e in errors)
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
