"""Policies: the engine's registry, so clients build their menus and colours from it."""

from __future__ import annotations

from fastapi import APIRouter

from app.api.deps import Viewer
from app.api.schemas import PolicyRead
from engine import policy_table

router = APIRouter(prefix="/policies", tags=["policies"], dependencies=[Viewer])


@router.get("")
async def list_policies() -> list[PolicyRead]:
    """Every registered policy in registration order, with its label, colour and description."""
    return [PolicyRead(**p) for p in policy_table()]
