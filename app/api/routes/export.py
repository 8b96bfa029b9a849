"""A stored mission as an MCAP file for Foxglove and other robotics tools (`app/export/`)."""

from __future__ import annotations

import threading
from collections.abc import AsyncIterator, Generator

import anyio
from fastapi import APIRouter, HTTPException, Request, status
from fastapi.responses import StreamingResponse

from app.api.deps import MissionId, MissionsDep, Viewer
from app.export import source
from app.export.writer import mcap_blocks

router = APIRouter(prefix="/missions/{mission_id}", tags=["history"], dependencies=[Viewer])

#: Exports streaming at once: each replays its mission on an engine of its own.
EXPORTS = 2
MEDIA_TYPE = "application/x-mcap"


def _slots(request: Request) -> threading.BoundedSemaphore:
    state = request.app.state
    if getattr(state, "export_slots", None) is None:
        state.export_slots = threading.BoundedSemaphore(EXPORTS)
    slots: threading.BoundedSemaphore = state.export_slots
    return slots


async def _stream(
    blocks: Generator[bytes, None, None], slots: threading.BoundedSemaphore
) -> AsyncIterator[bytes]:
    """The blocks, each made on a worker thread (database pages, replay steps); however the
    stream ends (done, failed, the client gone) the writer is closed on a worker thread too
    (its replay engine takes the engine gate) and the export's slot is given back."""
    try:
        while (block := await anyio.to_thread.run_sync(next, blocks, None)) is not None:
            yield block
    finally:
        with anyio.CancelScope(shield=True):
            await anyio.to_thread.run_sync(blocks.close)
        slots.release()


@router.get(
    "/export.mcap",
    response_class=StreamingResponse,
    responses={200: {"content": {MEDIA_TYPE: {}}, "description": "the MCAP file"}},
)
async def export_mcap(
    mission_id: MissionId, missions: MissionsDep, request: Request
) -> StreamingResponse:
    """The mission as an MCAP file (Foxglove's JSON schemas): poses, robot states, events,
    auctions and bids, sites, operator actions; streamed as written. A live mission is
    exported as far as it has run; a field mission has no poses (none are stored)."""
    await missions.fresh(mission_id)  # 404 for an unknown mission; a live one's log flushed
    stored = await missions.store.read(source.load_now, mission_id)
    if stored is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"mission {mission_id} does not exist")
    slots = _slots(request)
    if not slots.acquire(blocking=False):
        raise HTTPException(
            status.HTTP_429_TOO_MANY_REQUESTS,
            f"{EXPORTS} exports are already streaming; retry when one has finished",
            headers={"Retry-After": "5"},
        )
    blocks = mcap_blocks(missions.store.read_now, stored, missions.gate.stepping)
    return StreamingResponse(
        _stream(blocks, slots),
        media_type=MEDIA_TYPE,
        headers={"Content-Disposition": f'attachment; filename="mission-{mission_id}.mcap"'},
    )
