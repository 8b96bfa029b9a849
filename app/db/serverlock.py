"""One server per database server-side: a PostgreSQL advisory lock held for the server's life.

The data folder's `flock` (app/datalock.py) keeps two servers off one folder and one SQLite
file, but two servers on two folders can name the same PostgreSQL database, and each would
then mark the other's live missions interrupted and run the same sweeps. So on PostgreSQL a
server also takes a session-level advisory lock on the database, on a connection of its own
kept open until it stops; the database drops the lock when that connection ends, however the
process ends. The connection's `application_name` carries the holder's pid, so a refused
start can name it. (Other databases have no such lock; SQLite needs none: its file is
locked.)
"""

from __future__ import annotations

import contextlib
import os

from sqlalchemy import Connection, Engine, create_engine, text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.pool import NullPool

#: the advisory lock's key: "regolith" in ASCII, as a signed 64-bit number
LOCK_KEY = int.from_bytes(b"regolith", "big") - 2**63
APP_NAME = "regolith server pid "


class DatabaseBusy(RuntimeError):
    """Another Regolith server holds the database; the message names it."""


class DatabaseUnreachable(RuntimeError):
    """The database cannot be reached; the message says why, in one line."""


class ServerLock:
    """The advisory lock on a PostgreSQL database; `release()` drops it."""

    def __init__(self, url: str) -> None:
        self.url = url
        self._engine: Engine | None = None
        self._conn: Connection | None = None

    def acquire(self) -> ServerLock:
        shown = make_url(self.url).render_as_string(hide_password=True)
        engine = create_engine(
            self.url,
            poolclass=NullPool,
            connect_args={"application_name": f"{APP_NAME}{os.getpid()}", "connect_timeout": 10},
        )
        try:
            conn = engine.connect()
        except SQLAlchemyError as exc:
            engine.dispose()
            first = str(getattr(exc, "orig", exc) or exc).strip().splitlines()
            raise DatabaseUnreachable(
                f"database {shown}: cannot connect ({first[0] if first else type(exc).__name__})"
            ) from None
        try:
            got = conn.scalar(text("select pg_try_advisory_lock(:k)"), {"k": LOCK_KEY})
            conn.commit()  # the lock is the session's: it outlives this transaction
            if not got:
                holder = conn.scalar(
                    text(
                        "select a.application_name from pg_locks l join pg_stat_activity a "
                        "on a.pid = l.pid where l.locktype = 'advisory' and l.granted "
                        "and l.database = (select oid from pg_database "
                        "where datname = current_database()) "
                        "and l.objsubid = 1 and l.classid = :hi and l.objid = :lo limit 1"
                    ),  # a bigint key is shown as its two halves
                    {"hi": (LOCK_KEY >> 32) & 0xFFFFFFFF, "lo": LOCK_KEY & 0xFFFFFFFF},
                )
                who = str(holder).removeprefix(APP_NAME) if holder else ""
                pid = f"pid {who}; " if who.isdigit() else ""
                raise DatabaseBusy(
                    f"database {shown} is in use by another Regolith server ({pid}advisory lock); "
                    "stop it first, or use another --db"
                )
        except BaseException:
            conn.close()
            engine.dispose()
            raise
        self._engine, self._conn = engine, conn
        return self

    def release(self) -> None:
        if self._conn is not None:
            # unlocked before the close: the close returns before PostgreSQL's backend has
            # exited (and let go of the session's locks), so a server restarted at once on a
            # busy machine could find the lock still held and be refused
            with contextlib.suppress(SQLAlchemyError):
                self._conn.scalar(text("select pg_advisory_unlock(:k)"), {"k": LOCK_KEY})
                self._conn.commit()
            self._conn.close()  # ends the session (and the lock, had the unlock failed)
            self._conn = None
        if self._engine is not None:
            self._engine.dispose()
            self._engine = None

    @property
    def held(self) -> bool:
        return self._conn is not None


def needs_server_lock(url: str) -> bool:
    """True for a PostgreSQL URL (the only database here with advisory locks)."""
    return make_url(url).get_backend_name() == "postgresql"
