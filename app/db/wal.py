"""Keep a SQLite file's write-ahead log small: checkpoints from a thread of the server's own.

The server turns SQLite's automatic checkpoints off (they would copy the WAL back, with an
fsync, inside a commit) and checkpoints here instead, never inside a commit. A PASSIVE
checkpoint copies what it can without waiting for anyone, but it never shrinks the file, and
while a mission at "max" writes without pause the log never wraps to its start: it grew to
hundreds of MB. So: every `every_s` this thread looks at the -wal file, and

- if it is over `truncate_above` bytes, or has stopped growing (the writer is idle), runs a
  TRUNCATE checkpoint: it briefly holds new writes back (at most `busy_ms` waiting for
  readers, then the copy), copies everything and empties the file;
- otherwise runs a PASSIVE one.

`journal_size_limit` (set on every connection, `app/db/session.py`) also trims the file
whenever SQLite restarts the log by itself. A checkpoint that cannot finish (busy) is simply
tried again on the next turn.
"""

from __future__ import annotations

import logging
import threading
from pathlib import Path

from sqlalchemy import Engine

from app.db.session import BUSY_TIMEOUT_MS

log = logging.getLogger("regolith.wal")

TRUNCATE_ABOVE = 8 * 1024 * 1024
BUSY_MS = 200


class WalCheckpointer:
    """A daemon thread checkpointing `engine`'s SQLite file until `close()`."""

    def __init__(
        self,
        engine: Engine,
        path: Path,
        every_s: float = 1.0,
        truncate_above: int = TRUNCATE_ABOVE,
        busy_ms: int = BUSY_MS,
    ) -> None:
        self.engine = engine
        self.wal = path.with_name(path.name + "-wal")
        self.every_s = every_s
        self.truncate_above = truncate_above
        self.busy_ms = busy_ms
        self.truncations = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="regolith-checkpoint", daemon=True)
        self._thread.start()

    def _size(self) -> int:
        try:
            return self.wal.stat().st_size
        except FileNotFoundError:
            return 0

    def _run(self) -> None:
        last = -1
        while not self._stop.wait(self.every_s):
            size = self._size()
            if size == 0:
                last = 0
                continue
            if size > self.truncate_above or size == last:
                self.checkpoint("TRUNCATE", self.busy_ms)
                last = self._size()
            else:
                self.checkpoint("PASSIVE")
                last = size

    def checkpoint(self, mode: str, busy_ms: int | None = None) -> bool:
        """One checkpoint; True if it completed (a busy database is tried again later)."""
        try:
            with self.engine.connect() as conn:
                if busy_ms is not None:  # wait briefly: writers queue behind a pending TRUNCATE
                    conn.exec_driver_sql(f"PRAGMA busy_timeout={int(busy_ms)}")
                try:
                    row = conn.exec_driver_sql(f"PRAGMA wal_checkpoint({mode})").fetchone()
                finally:
                    if busy_ms is not None:
                        conn.exec_driver_sql(f"PRAGMA busy_timeout={BUSY_TIMEOUT_MS}")
        except Exception:
            log.warning("WAL checkpoint (%s) failed", mode, exc_info=True)
            return False
        done = row is not None and row[0] == 0
        if done and mode == "TRUNCATE":
            self.truncations += 1
        return done

    def close(self) -> None:
        """Stop the thread and leave the log empty (call after the last write)."""
        self._stop.set()
        self._thread.join()
        self.checkpoint("TRUNCATE")
