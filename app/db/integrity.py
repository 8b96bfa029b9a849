"""A damaged SQLite file is refused at start, not discovered later by a failing write.

SQLite reads damaged pages without complaint until a query happens to touch them; a server
would then start, accept missions and fail mid-write, maybe after hours. `PRAGMA
quick_check` reads every page once at start (seconds for a large file) and names what is
wrong, so the operator learns it from the start command, with the file to restore.
"""

from __future__ import annotations

import sqlite3
from contextlib import closing
from pathlib import Path

from sqlalchemy.engine import URL, make_url

PROBLEMS_SHOWN = 3
_HEADER = "*** in database main ***"


class CorruptDatabase(RuntimeError):
    """The file is damaged; the message names it and its first problems."""


def sqlite_file(database_url: str | URL) -> Path | None:
    """The SQLite file a database URL names, or None (another database, or in memory)."""
    url = make_url(database_url)
    if url.get_backend_name() != "sqlite" or url.database in (None, "", ":memory:"):
        return None
    return Path(url.database)


def check_sqlite(path: Path) -> None:
    """Raise CorruptDatabase unless `PRAGMA quick_check` finds `path` sound (or it is new)."""
    if not path.exists() or path.stat().st_size == 0:
        return
    try:
        with closing(sqlite3.connect(path, timeout=10)) as conn:
            rows = conn.execute(f"PRAGMA quick_check({PROBLEMS_SHOWN})").fetchall()
    except sqlite3.DatabaseError as exc:  # a header it cannot read: "file is not a database"
        problems = [str(exc)]
    else:
        problems = [str(r[0]).replace(_HEADER, "") for r in rows if r and r[0] != "ok"]
    if problems:
        shown = "; ".join(" ".join(p.split()) for p in problems[:PROBLEMS_SHOWN])
        raise CorruptDatabase(
            f"database {path} is damaged (PRAGMA quick_check: {shown}); "
            "restore it from a backup, or move it aside to start with an empty one"
        )
