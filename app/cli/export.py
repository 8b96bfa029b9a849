"""`regolith export MISSION --out FILE.mcap`: a stored mission as an MCAP file, read straight
from the database (a running server may keep using it: nothing is written there)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Any

import typer

from app.cli.errors import fail
from app.cli.options import DataDir, DbUrl
from app.cli.serve import _settings


def export(
    mission: Annotated[int, typer.Argument(metavar="MISSION", help="Mission id.", min=1)],
    out: Annotated[
        Path, typer.Option("--out", metavar="FILE", help="The MCAP file to write (.mcap).")
    ],
    db: DbUrl = None,
    data_dir: DataDir = None,
) -> None:
    """Write a stored mission (simulated or field) as an MCAP file for Foxglove and other
    robotics tools: poses and robot states (simulated missions, rebuilt by replay), every
    event, auctions and bids, sites, operator actions (docs/service.md, Export to MCAP)."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import SQLAlchemyError

    from app.db.session import make_engine, make_sessionmaker
    from app.export import source
    from app.export.writer import mcap_blocks
    from app.settings import Settings

    settings = _settings("export", db, data_dir)
    assert isinstance(settings, Settings)
    url = make_url(settings.database_url)
    file = url.database if url.get_backend_name() == "sqlite" else None
    if file not in (None, "", ":memory:") and not Path(str(file)).is_file():
        fail("export", f"no database at {url.database} (see --db and --data-dir)")
    if out.is_dir():
        fail("export", f"--out {out}: is a directory; name the file to write")
    if not out.parent.is_dir():
        fail("export", f"--out {out}: folder {out.parent} does not exist")
    engine = make_engine(settings.database_url)
    sessions = make_sessionmaker(engine)

    def read(fn: Any, *args: Any) -> Any:
        with sessions() as session:
            return fn(session, *args)

    partial = out.with_name(f".{out.name}.partial")
    try:
        stored = read(source.load_now, mission)
        if stored is None:
            fail("export", f"mission {mission} does not exist in {settings.database_url}")
        size = 0
        with partial.open("wb") as f:
            for block in mcap_blocks(read, stored, gate=_no_gate):
                f.write(block)
                size += len(block)
        os.replace(partial, out)  # a failed export leaves no half-written file behind
    except SQLAlchemyError as exc:
        fail("export", f"cannot read the database: {str(exc).splitlines()[0]}", 1)
    except OSError as exc:
        fail("export", f"--out {out}: {exc.strerror or exc}", 1)
    finally:
        partial.unlink(missing_ok=True)
        engine.dispose()
    poses = "poses replayed" if stored.mode == "simulated" else "no poses (field mission)"
    typer.echo(f"mission {mission} ({stored.mode}, {poses}): {size:,} bytes written to {out}")


def _no_gate() -> Any:
    """The CLI's engine is its own: nothing else steps it."""
    import contextlib

    return contextlib.nullcontext()


def register(cli: typer.Typer) -> None:
    """Add `export` to the `regolith` command."""
    cli.command(name="export")(export)
