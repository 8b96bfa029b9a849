"""The application factory: `create_app(settings)`; the lifespan owns every resource."""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import AsyncExitStack, asynccontextmanager

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from starlette.concurrency import run_in_threadpool

from app import logs
from app.api import docs, errors
from app.api.deps import Services
from app.api.routes import api_router
from app.datalock import DataLock
from app.db.integrity import sqlite_file
from app.db.migrate import upgrade
from app.db.session import make_engine, make_sessionmaker
from app.db.wal import WalCheckpointer
from app.live.runner import MissionRunner
from app.metrics import metrics_registry
from app.middleware import (
    LimitBodyMiddleware,
    RejectNulMiddleware,
    RequestContextMiddleware,
    SecurityHeadersMiddleware,
)
from app.ratelimit import RateLimiter
from app.security import resolve_token
from app.services.commands import RobotCommands
from app.services.field_links import reattach
from app.services.missions import MissionService
from app.services.playback import Playback
from app.services.store import Store
from app.settings import Settings
from app.startup import preflight
from app.sweeps import routes as sweep_routes
from app.sweeps.service import SweepManager

log = logging.getLogger("regolith")

_NO_DASHBOARD = """<!doctype html><title>Regolith</title>
<p>The dashboard is not installed (no frontend/ folder). The API is at <a href="/docs">/docs</a>.
"""


def _lifespan(settings: Settings, held: DataLock | None):  # type: ignore[no-untyped-def]
    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        async with AsyncExitStack() as stack:
            if held is None or not held.held:  # else `regolith serve` took it and keeps it
                lock = await run_in_threadpool(preflight, settings)
                stack.callback(lock.release)
            stack.callback(logs.uninstall, logs.install())
            token = resolve_token(settings)
            engine = make_engine(settings.database_url, autocheckpoint=False)
            stack.callback(engine.dispose)
            await run_in_threadpool(upgrade, engine, settings.migrations_dir)
            if (path := sqlite_file(settings.database_url)) is not None:
                wal = WalCheckpointer(engine, path)
                stack.callback(wal.close)  # after the store's last write
            store = Store(make_sessionmaker(engine))
            stack.callback(store.close)
            runner = MissionRunner(settings, store)
            await runner.start()
            stack.push_async_callback(runner.aclose)
            # field missions whose robots mined on while no server ran: taken back
            attached = await reattach(store, runner)
            stale = await store.interrupt_stale(keep=attached)
            if stale:
                log.warning("%d mission(s) were left running; marked interrupted", stale)
            sweeps = SweepManager(settings, store)
            if stale := await sweeps.start():
                log.warning("%d sweep(s) were left running; marked interrupted", stale)
            stack.push_async_callback(sweeps.aclose)
            missions = MissionService(settings, store, runner)
            playback = Playback(settings, missions)
            stack.push_async_callback(playback.aclose)
            app.state.services = Services(
                settings=settings,
                store=store,
                runner=runner,
                missions=missions,
                commands=RobotCommands(missions),
                playback=playback,
                sweeps=sweeps,
                token=token,
                limiter=RateLimiter(settings.rate_limit_per_s, settings.rate_limit_burst),
                metrics=metrics_registry(runner, store, playback),
            )
            yield

    return lifespan


def create_app(settings: Settings | None = None, held: DataLock | None = None) -> FastAPI:
    """A fresh application; nothing happens until its lifespan starts.

    The lifespan takes the data folder's lock and checks the database (`app/startup.py`)
    unless the caller already did and passes the lock it holds as `held`.
    """
    settings = settings or Settings()
    app = FastAPI(
        title="Regolith",
        summary="Mission control for auction-based lunar mining robot teams",
        version="0.1.0",
        lifespan=_lifespan(settings, held),
        docs_url=None,  # app/api/docs.py: the same pages, with their assets served locally
        redoc_url=None,
    )
    errors.install(app)
    docs.install(app)
    app.include_router(api_router)
    app.include_router(sweep_routes.router, prefix="/api")
    app.add_middleware(LimitBodyMiddleware, max_bytes=1_000_000)
    app.add_middleware(RejectNulMiddleware)
    app.add_middleware(SecurityHeadersMiddleware)
    if settings.cors_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=settings.cors_origins,
            allow_methods=["GET", "POST", "PUT"],
            allow_headers=["Authorization", "Content-Type", "X-Request-ID"],
            expose_headers=["X-Request-ID"],
        )
    app.add_middleware(RequestContextMiddleware)  # outermost: every answer has a request id
    if (settings.frontend_dir / "index.html").is_file() or settings.frontend_dir.is_dir():
        app.mount("/", StaticFiles(directory=settings.frontend_dir, html=True), name="dashboard")
    else:

        @app.get("/", include_in_schema=False)
        async def no_dashboard() -> HTMLResponse:
            return HTMLResponse(_NO_DASHBOARD)

    return app
