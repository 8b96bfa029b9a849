"""Scenarios: the reference one, as a template for `POST /api/missions` bodies."""

from __future__ import annotations

from fastapi import APIRouter

from app.api.deps import Viewer
from engine import Scenario, reference_scenario

router = APIRouter(prefix="/scenarios", tags=["scenarios"], dependencies=[Viewer])


@router.get("/reference")
async def reference() -> Scenario:
    """The reference scenario (docs/spec.md §2) with every default spelled out."""
    return reference_scenario()
