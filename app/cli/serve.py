"""`regolith serve` and `regolith db upgrade`: the server and its schema from the command line."""

from __future__ import annotations

import contextlib
import errno
import socket
from pathlib import Path
from typing import Annotated

import typer

from app.cli.errors import fail as _fail
from app.cli.options import DataDir, DbUrl

#: Seconds an idle HTTP connection is kept open. The client must be the one to close it: a
#: server that closes first (uvicorn's default, 5 s, is also httpx's own expiry) races a
#: client's next request on that connection, which then meets a reset instead of an answer.
KEEP_ALIVE_S = 75


def _settings(command: str, db: str | None, data_dir: Path | None) -> object:
    """Settings from the environment, overridden by the options given; bad values exit 2."""
    from pydantic import ValidationError
    from sqlalchemy import create_engine
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError, NoSuchModuleError

    from app.settings import Settings

    overrides: dict[str, object] = {}
    if db is not None:
        overrides["db_url"] = db
    if data_dir is not None:
        overrides["data_dir"] = data_dir
    try:
        settings = Settings(**overrides)  # type: ignore[arg-type]
    except ValidationError as exc:
        err = exc.errors()[0]
        _fail(command, f"{'.'.join(map(str, err['loc']))}: {err['msg']}")
    if settings.data_dir.exists() and not settings.data_dir.is_dir():
        _fail(command, f"--data-dir {settings.data_dir}: not a directory")
    try:
        url = make_url(settings.database_url)
        create_engine(url).dispose()  # loads the dialect and its driver, connects to nothing
    except ArgumentError:
        _fail(command, f"--db {settings.database_url!r}: not a database URL (e.g. sqlite:///x.db)")
    except (ImportError, NoSuchModuleError) as exc:
        _fail(command, f"--db: no driver for {url.drivername!r} installed ({exc})")
    return settings


def _listen(host: str, port: int) -> socket.socket:
    """The server's socket, bound (as uvicorn binds it) before anything is printed: a port in
    use is one line, not a banner with a URL that will never answer."""
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
    except OSError as exc:  # in use, not an address of this machine, a privileged port …
        sock.close()
        why = "in use by another program" if exc.errno == errno.EADDRINUSE else exc.strerror
        bad_host = isinstance(exc, socket.gaierror) or exc.errno == errno.EADDRNOTAVAIL
        option = f"--host {host}" if bad_host else f"--port {port}"
        _fail("serve", f"{option}: cannot listen on {host}:{port} ({why or exc})")
    return sock


def serve(
    host: Annotated[
        str, typer.Option("--host", metavar="ADDRESS", help="Interface to listen on.")
    ] = "127.0.0.1",
    port: Annotated[int, typer.Option("--port", metavar="PORT", help="TCP port.")] = 8000,
    db: DbUrl = None,
    data_dir: Annotated[
        Path | None,
        typer.Option(
            "--data-dir", metavar="DIR", help="Database, token and logs (default ./data)."
        ),
    ] = None,
    log_level: Annotated[
        str,
        typer.Option(
            "--log-level", metavar="LEVEL", help="critical|error|warning|info|debug|trace."
        ),
    ] = "info",
    log_format: Annotated[
        str,
        typer.Option(
            "--log-format",
            metavar="FORMAT",
            envvar="REGOLITH_LOG_FORMAT",
            help="json (one object per line), text, or auto: text on a terminal, else json.",
        ),
    ] = "auto",
) -> None:
    """Serve the API, the live stream and the dashboard (migrating the database first)."""
    import uvicorn

    from app import logs
    from app.main import create_app
    from app.security import resolve_token
    from app.settings import Settings
    from app.startup import StartupRefused, preflight

    if not 0 < port < 65536:
        _fail("serve", f"--port {port}: must be between 1 and 65535")
    if log_level not in ("critical", "error", "warning", "info", "debug", "trace"):
        _fail("serve", f"--log-level {log_level}: choose critical|error|warning|info|debug")
    if log_format not in ("auto", "json", "text"):
        _fail("serve", f"--log-format {log_format}: choose auto|json|text")
    settings = _settings("serve", db, data_dir)
    assert isinstance(settings, Settings)
    sock = _listen(host, port)
    try:
        token = resolve_token(settings)
    except OSError as exc:
        _fail("serve", f"--data-dir {settings.data_dir}: {exc.strerror or exc}", 1)
    try:
        lock = preflight(settings)  # held until this process ends
    except StartupRefused as exc:
        _fail("serve", str(exc), 1)
    shown = "(from REGOLITH_TOKEN)" if settings.token is not None else token
    where = f"{settings.data_dir / 'operator-token'}" if settings.token is None else "env"
    browse = "127.0.0.1" if host in ("0.0.0.0", "::") else host
    typer.echo(
        f"Regolith dashboard: http://{browse}:{port}/   API docs: http://{browse}:{port}/docs"
    )
    typer.echo(f"Operator token: {shown}   (kept in {where})")
    fmt: logs.LogFormat = "json" if log_format == "json" else "text"
    logs.configure(
        logs.default_format() if log_format == "auto" else fmt,
        "DEBUG" if log_level == "trace" else log_level.upper(),
    )
    config = uvicorn.Config(
        create_app(settings, held=lock),
        host=host,
        port=port,
        log_level=log_level,
        log_config=None,  # keep the handlers configured above
        access_log=False,  # regolith.access logs every request, with its ids and duration
        ws_max_size=max(65536, settings.ws_max_message),
        timeout_graceful_shutdown=5,
        timeout_keep_alive=KEEP_ALIVE_S,
        # X-Forwarded-For is Regolith's to judge (REGOLITH_TRUSTED_PROXIES), not uvicorn's
        proxy_headers=False,
    )
    server = uvicorn.Server(config)
    with sock, contextlib.suppress(KeyboardInterrupt):  # uvicorn re-raises SIGINT when done
        server.run(sockets=[sock])
    if not server.started:  # the application refused to start; its log says why
        raise typer.Exit(1)


def upgrade(
    db: DbUrl = None,
    data_dir: DataDir = None,
) -> None:
    """Apply the Alembic migrations up to the newest (safe to repeat)."""
    from sqlalchemy.exc import SQLAlchemyError

    from app.db.migrate import upgrade as do_upgrade
    from app.db.session import make_engine
    from app.settings import Settings
    from app.startup import StartupRefused, preflight

    settings = _settings("db upgrade", db, data_dir)
    assert isinstance(settings, Settings)
    try:
        lock = preflight(settings)  # never migrate under a running server, nor a damaged file
    except StartupRefused as exc:
        _fail("db upgrade", str(exc), 1)
    try:
        engine = make_engine(settings.database_url)
        try:
            do_upgrade(engine, settings.migrations_dir)
        finally:
            engine.dispose()
    except (SQLAlchemyError, OSError) as exc:
        _fail("db upgrade", f"{type(exc).__name__}: {str(exc).splitlines()[0]}", 1)
    finally:
        lock.release()
    typer.echo(f"database at head: {settings.database_url}")


def register(cli: typer.Typer) -> None:
    """Add `serve` and the `db` group to the `regolith` command."""
    cli.command(name="serve")(serve)
    db_cli = typer.Typer(name="db", help="Database schema.", no_args_is_help=True)
    db_cli.command(name="upgrade")(upgrade)
    cli.add_typer(db_cli, name="db")
