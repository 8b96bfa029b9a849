"""What must hold before a server (or a migration) touches the data: checked in one place.

`regolith serve` runs this before uvicorn, so a refusal is one line on stderr and exit code
1, not a lifespan traceback; an application started another way (tests, an embedding ASGI
server) runs it in its lifespan instead. First the data folder's lock (one server per
folder), then, holding it, the SQLite integrity check (nobody can be writing meanwhile), or
on PostgreSQL the database's advisory lock (one server per database, whatever its folder),
which also tells at once when the database cannot be reached. A SQLite file is locked beside
it (`<file>.lock`), so the lock follows the database whatever the data folder; a database
that can be locked neither way is refused rather than shared unguarded.
"""

from __future__ import annotations

from sqlalchemy.engine import make_url

from app.datalock import DataDirBusy, DataLock, lock_paths
from app.db.integrity import CorruptDatabase, check_sqlite, sqlite_file
from app.db.serverlock import DatabaseBusy, DatabaseUnreachable, ServerLock, needs_server_lock
from app.settings import Settings


class StartupRefused(RuntimeError):
    """The server must not start; the message says why, in one line."""


def preflight(settings: Settings) -> DataLock:
    """Take the data folder's lock and check the database; the caller releases the lock."""
    path = sqlite_file(settings.database_url)
    lock = DataLock(lock_paths(settings.data_dir, path))
    try:
        lock.acquire()
        if path is not None:
            check_sqlite(path)
        elif needs_server_lock(settings.database_url):
            lock.hold(ServerLock(settings.database_url).acquire())
        elif not _private(settings.database_url):
            raise StartupRefused(
                f"--db {make_url(settings.database_url).render_as_string(hide_password=True)}: "
                "no way to lock this database against a second server; use SQLite or PostgreSQL"
            )
    except (DataDirBusy, CorruptDatabase, DatabaseBusy, DatabaseUnreachable) as exc:
        lock.release()
        raise StartupRefused(str(exc)) from None
    except StartupRefused:
        lock.release()
        raise
    except OSError as exc:
        lock.release()
        raise StartupRefused(f"data folder {settings.data_dir}: {exc.strerror or exc}") from None
    return lock


def _private(url: str) -> bool:
    """An in-memory SQLite database: no other process can open it, so it needs no lock."""
    return make_url(url).get_backend_name() == "sqlite"
