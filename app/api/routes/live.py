"""The live stream: `/api/missions/{id}/live` (protocol in docs/service.md)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, WebSocket

from app.api.convert import mission_read
from app.api.deps import get_services
from app.db.models import Mission as MissionRow
from app.live.hub import CLOSE_POLICY, serve_viewer
from app.security import token_matches
from app.services.errors import Conflict, LimitExceeded, NotFound
from app.services.live_state import LiveState

router = APIRouter(tags=["live"])

CLOSE_NOT_FOUND = 4404
CLOSE_BUSY = 1013
MAX_ID = 2**31 - 1
"""Ids are 32-bit like the REST routes' `MissionId`; checked after accepting, so the client
sees a close code and reason rather than a refused handshake."""


def _render(row: MissionRow, state: LiveState | None) -> dict[str, Any]:
    return mission_read(row, state).model_dump(mode="json")


@router.websocket("/missions/{mission_id}/live")
async def live(ws: WebSocket, mission_id: int) -> None:
    """Snapshot on connect, then frames, auctions, events and status messages."""
    services = get_services(ws)
    settings = services.settings
    await ws.accept()
    if not 1 <= mission_id <= MAX_ID:  # 10**30 overflowed the database driver (a 500)
        await ws.close(code=CLOSE_POLICY, reason=f"mission_id: must be 1..{MAX_ID}")
        return
    if settings.read_requires_token:
        given = ws.query_params.get("token", "")
        if not token_matches(given, services.token):
            await ws.close(code=CLOSE_POLICY, reason="operator token required")
            return
    try:
        hub, viewer = await services.missions.watch(mission_id, ws, _render)
    except NotFound:
        await ws.close(code=CLOSE_NOT_FOUND, reason=f"mission {mission_id} not found")
        return
    except LimitExceeded as exc:
        await ws.close(code=CLOSE_BUSY, reason=exc.message)
        return
    except Conflict as exc:  # the mission's own data failed it as the viewer joined
        await ws.close(code=CLOSE_POLICY, reason=exc.message[:120])
        return
    try:
        await serve_viewer(ws, hub, viewer, settings.ws_max_message)
    finally:
        services.runner.forget_hub(mission_id)
