"""Database engine and session factory; SQLite gets WAL and foreign keys on every connection."""

from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, sessionmaker

BUSY_TIMEOUT_MS = 10_000
#: SQLite trims the WAL file to this size whenever it restarts the log (else the file keeps
#: its largest size forever); see app/db/wal.py for the checkpoints that make it restart.
JOURNAL_SIZE_LIMIT = 4 * 1024 * 1024


def _sqlite_pragmas(dbapi_conn: Any, _record: Any, autocheckpoint: bool) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")
    cur.execute("PRAGMA synchronous=NORMAL")
    cur.execute("PRAGMA foreign_keys=ON")
    cur.execute(f"PRAGMA busy_timeout={BUSY_TIMEOUT_MS}")
    cur.execute(f"PRAGMA journal_size_limit={JOURNAL_SIZE_LIMIT}")
    if not autocheckpoint:  # the server checkpoints from its own thread (app/db/wal.py)
        cur.execute("PRAGMA wal_autocheckpoint=0")
    cur.close()


def make_engine(url: str, autocheckpoint: bool = True) -> Engine:
    """An engine for any SQLAlchemy URL; a file SQLite database gets its folder created.

    `autocheckpoint=False` keeps SQLite from copying the WAL back (with an fsync) inside a
    commit; the caller must then checkpoint itself.
    """
    parsed = make_url(url)
    if parsed.get_backend_name() != "sqlite":
        return create_engine(url, pool_pre_ping=True)
    if parsed.database and parsed.database != ":memory:":
        Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
    engine = create_engine(url, connect_args={"check_same_thread": False})
    event.listen(engine, "connect", partial(_sqlite_pragmas, autocheckpoint=autocheckpoint))
    return engine


def make_sessionmaker(engine: Engine) -> sessionmaker[Session]:
    """Sessions that keep loaded objects usable after commit (they are turned into schemas)."""
    return sessionmaker(engine, expire_on_commit=False)
