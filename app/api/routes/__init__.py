"""One router per resource; `api_router` gathers them under /api."""

from __future__ import annotations

from fastapi import APIRouter

from app.api.routes import health, history, live, missions, robots, scenarios

api_router = APIRouter(prefix="/api")
for _module in (health, scenarios, missions, robots, history, live):
    api_router.include_router(_module.router)
