"""One server per data folder: an exclusive `flock` on `<data dir>/regolith.lock`.

Two servers on one SQLite file each believe they own its live missions and sweeps: each
marks the other's missions interrupted at start, both checkpoint the WAL and write the same
sweep folders. So a server (and `regolith db upgrade`) takes this lock first and holds it for
its lifetime; the kernel drops it when the process ends, however it ends (kill -9 included),
so a stale lock file never blocks a restart. The lock is on the data folder whatever the
database (the folder also holds the token and the sweeps), and the lock follows the database
too: a SQLite file is always locked through a `<file>.lock` beside it, wherever it lies, so a
second server with another `--data-dir` whose `--db` names the first one's file is refused.
(A PostgreSQL database is locked in the database itself: app/db/serverlock.py.)
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path
from typing import Protocol

LOCK_NAME = "regolith.lock"


class DataDirBusy(RuntimeError):
    """Another process holds the lock; the message names the folder and that process."""


class _Held(Protocol):
    def release(self) -> None: ...


class DataLock:
    """Exclusive locks on some files, held until `release()` or the end of the process.

    `hold(lock)` adds another lock (the database's, app/db/serverlock.py) released with them.
    """

    def __init__(self, paths: list[Path]) -> None:
        self.paths = paths
        self._fds: list[int] = []
        self._also: list[_Held] = []

    def hold(self, lock: _Held) -> None:
        self._also.append(lock)

    def acquire(self) -> DataLock:
        try:
            for path in self.paths:
                self._fds.append(_lock(path))
        except BaseException:
            self.release()
            raise
        return self

    def release(self) -> None:
        for lock in reversed(self._also):
            lock.release()
        self._also.clear()
        for fd in reversed(self._fds):
            os.close(fd)  # closing the only descriptor drops the flock
        self._fds.clear()

    @property
    def held(self) -> bool:
        return bool(self._fds)


def lock_paths(data_dir: Path, sqlite_file: Path | None) -> list[Path]:
    """The data folder's lock, and the SQLite file's (beside it, in the folder or not)."""
    paths = [data_dir.resolve() / LOCK_NAME]
    if sqlite_file is not None:
        db = sqlite_file.resolve()  # a symlinked path or a relative one: the same lock
        paths.append(db.with_name(db.name + ".lock"))
    return paths


def _lock(path: Path) -> int:
    path.parent.mkdir(parents=True, exist_ok=True)
    # O_CLOEXEC (Python's default): a spawned helper never inherits, and so never keeps, it
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _holder(fd)
        os.close(fd)
        folder = path.name == LOCK_NAME
        what = f"data folder {path.parent}" if folder else f"database {path.with_suffix('')}"
        raise DataDirBusy(
            f"{what} is in use by another Regolith server ({holder}lock {path}); "
            f"stop it first, or use another {'--data-dir' if folder else '--db'}"
        ) from None
    except BaseException:
        os.close(fd)
        raise
    os.ftruncate(fd, 0)
    os.write(fd, f"{os.getpid()}\n".encode())
    return fd


def _holder(fd: int) -> str:
    """`"pid N; "` from the lock file, if the holder wrote it."""
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
    except OSError:
        return ""
    return f"pid {text}; " if text.isdigit() else ""
