"""The live stream: `/api/missions/{id}/live` (protocol in docs/service.md)."""

from __future__ import annotations

from fastapi import APIRouter, WebSocket

from app.api.convert import mission_read
from app.api.deps import get_services
from app.live import CLOSE_POLICY, Viewer, encode, serve_viewer
from app.security import token_matches
from app.services.errors import NotFound

router = APIRouter(tags=["live"])

CLOSE_NOT_FOUND = 4404
CLOSE_BUSY = 1013


@router.websocket("/missions/{mission_id}/live")
async def live(ws: WebSocket, mission_id: int) -> None:
    """Snapshot on connect, then frames, auctions, events and status messages."""
    services = get_services(ws)
    settings = services.settings
    await ws.accept()
    if settings.read_requires_token:
        given = ws.query_params.get("token", "")
        if not token_matches(given, services.token):
            await ws.close(code=CLOSE_POLICY, reason="operator token required")
            return
    try:
        parts, lm = await services.missions.snapshot(mission_id)
    except NotFound:
        await ws.close(code=CLOSE_NOT_FOUND, reason=f"mission {mission_id} not found")
        return
    # From the snapshot to joining nothing awaits, so no event can slip in between.
    hub = services.runner.hub(mission_id)
    if len(hub) >= settings.max_viewers:
        services.runner.forget_hub(mission_id)
        await ws.close(code=CLOSE_BUSY, reason=f"at most {settings.max_viewers} viewers")
        return
    message = {
        "type": "snapshot",
        "mission": mission_read(parts["row"], lm).model_dump(mode="json"),
        "map": parts["map"],
        "state": parts["state"],
    }
    viewer: Viewer = hub.join(ws, encode(message))
    try:
        await serve_viewer(ws, hub, viewer, settings.ws_max_message)
    finally:
        services.runner.forget_hub(mission_id)
