"""Token check: lets a client verify the operator token before keeping it."""

from __future__ import annotations

from fastapi import APIRouter

from app.api.deps import Operator
from app.api.schemas import AuthRead

router = APIRouter(prefix="/auth", tags=["auth"])


@router.get("/check", dependencies=[Operator])
async def check_token() -> AuthRead:
    """200 with the role the bearer token grants; 401 without a token, 403 with a wrong one
    (rate-limited per client address like every other refused token)."""
    return AuthRead(role="operator")
