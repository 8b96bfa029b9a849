"""Liveness for load balancers and the Docker HEALTHCHECK."""

from __future__ import annotations

from fastapi import APIRouter

from app.api.deps import ServicesDep
from app.api.schemas import Health

router = APIRouter(tags=["health"])


@router.get("/health")
async def health(services: ServicesDep) -> Health:
    """OK while the server runs; counts live missions and viewers."""
    runner = services.runner
    viewers = sum(len(h) for h in runner.hubs.values())
    return Health(
        status="ok", version="0.1.0", missions_live=runner.running_count(), viewers=viewers
    )
