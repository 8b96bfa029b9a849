"""Typed dependencies: `Annotated` aliases keep route signatures short."""

from __future__ import annotations

from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Annotated

from fastapi import Depends, HTTPException, Path, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from prometheus_client import CollectorRegistry
from starlette.requests import HTTPConnection

from app.clientaddr import client_address
from app.live.runner import MissionRunner
from app.ratelimit import RateLimiter
from app.security import token_matches
from app.services.commands import RobotCommands
from app.services.missions import MissionService
from app.services.playback import Playback
from app.services.store import Store
from app.settings import Settings
from app.sweeps.service import SweepManager


@dataclass
class Services:
    """Everything the lifespan owns that requests use."""

    settings: Settings
    store: Store
    runner: MissionRunner
    missions: MissionService
    commands: RobotCommands
    playback: Playback
    sweeps: SweepManager
    token: str
    limiter: RateLimiter
    metrics: CollectorRegistry
    """This app's Prometheus registry (`app/metrics.py`), not the process-global one."""


def get_services(conn: HTTPConnection) -> Services:
    services: Services = conn.app.state.services
    return services


async def services_dep(conn: HTTPConnection) -> Services:
    """Async on purpose: a plain `def` dependency would cost a thread-pool hop per request."""
    return get_services(conn)


ServicesDep = Annotated[Services, Depends(services_dep)]


async def get_missions(services: ServicesDep) -> MissionService:
    return services.missions


async def get_commands(services: ServicesDep) -> RobotCommands:
    return services.commands


async def get_playback(services: ServicesDep) -> Playback:
    return services.playback


MissionsDep = Annotated[MissionService, Depends(get_missions)]
CommandsDep = Annotated[RobotCommands, Depends(get_commands)]
PlaybackDep = Annotated[Playback, Depends(get_playback)]
MissionId = Annotated[int, Path(ge=1, le=2**31 - 1, description="mission id")]
RobotName = Annotated[
    str, Path(min_length=1, max_length=80, pattern=r"^[A-Za-z0-9_.-]+$", description="robot")
]

_bearer = HTTPBearer(auto_error=False, description="the operator token")
Credentials = Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]


def check_token(credentials: HTTPAuthorizationCredentials | None, expected: str) -> None:
    """401 without a bearer token, 403 with a wrong one."""
    if credentials is None:
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            "operator token required (Authorization: Bearer <token>)",
            headers={"WWW-Authenticate": "Bearer"},
        )
    if not token_matches(credentials.credentials, expected):
        raise HTTPException(status.HTTP_403_FORBIDDEN, "operator token is wrong")


OPERATOR_KEY = "operator"
"""The rate-limit bucket of whoever holds the operator token (there is one token)."""


def _limit(limiter: RateLimiter, key: str) -> None:
    wait = limiter.allow(key)
    if wait > 0:
        raise HTTPException(
            status.HTTP_429_TOO_MANY_REQUESTS,
            f"too many operator requests; retry in {wait:.1f} s",
            headers={"Retry-After": str(max(1, round(wait)))},
        )


async def require_operator(request: Request, credentials: Credentials) -> AsyncIterator[None]:
    """The operator token; while the request runs the simulation yields the CPU to it.

    Authentication comes first, so the rate limit is charged to the right party: the
    operator's allowance is its own, and requests without the right token are limited per
    client address (a flood of them cannot use up the operator's calls)."""
    services = get_services(request)
    given = credentials.credentials if credentials is not None else ""
    if credentials is not None and token_matches(given, services.token):
        _limit(services.limiter, OPERATOR_KEY)
    else:
        address = client_address(request, services.settings.trusted_proxies)
        _limit(services.limiter, f"address:{address}")
        check_token(credentials, services.token)
    with services.runner.operator_request():
        yield


async def require_viewer(request: Request) -> None:
    """Reads are public unless REGOLITH_READ_REQUIRES_TOKEN (so the schema shows no auth)."""
    services = get_services(request)
    if services.settings.read_requires_token:
        scheme, _, token = request.headers.get("authorization", "").partition(" ")
        given = None
        if scheme.lower() == "bearer" and token:
            given = HTTPAuthorizationCredentials(scheme=scheme, credentials=token)
        check_token(given, services.token)


Operator = Depends(require_operator)
Viewer = Depends(require_viewer)
