"""Liveness for load balancers and the Docker HEALTHCHECK."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import PlainTextResponse, Response

from app.api.deps import ServicesDep, Viewer
from app.api.schemas import Health
from app.metrics import CONTENT_TYPE, render

router = APIRouter(tags=["health"])


@router.get("/health")
async def health(services: ServicesDep) -> Health:
    """OK while the server runs; counts live missions and viewers."""
    runner = services.runner
    viewers = sum(len(h) for h in runner.hubs.values())
    return Health(
        status="ok", version="0.1.0", missions_live=runner.running_count(), viewers=viewers
    )


@router.get("/metrics", response_class=PlainTextResponse, dependencies=[Viewer])
async def metrics(services: ServicesDep) -> Response:
    """Prometheus text format: live missions, speeds, viewers, frame delay, DB writes."""
    with services.runner.gate:
        body = render(services.metrics)
    return Response(body, media_type=CONTENT_TYPE)
