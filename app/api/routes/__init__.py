"""One router per resource; `api_router` gathers them under /api."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from app.api.routes import (
    auth,
    export,
    health,
    history,
    live,
    missions,
    playback,
    policies,
    robots,
    scenarios,
)
from app.api.schemas import ErrorRead

_ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorRead, "description": text}
    for code, text in [
        (401, "operator token missing (mutating calls)"),
        (403, "operator token wrong"),
        (404, "unknown mission or robot"),
        (409, "the mission's state forbids it (finished, interrupted)"),
        (413, "request body too large"),
        (429, "a limit or the rate limit was reached"),
    ]
}
api_router = APIRouter(prefix="/api", responses=_ERRORS)
for _module in (
    health,
    auth,
    policies,
    scenarios,
    missions,
    robots,
    history,
    playback,
    export,
    live,
):
    api_router.include_router(_module.router)
