"""A throw-away PostgreSQL server for the tests: `initdb` + `pg_ctl` on a temporary folder.

Debian's server binaries live in /usr/lib/postgresql/<version>/bin (not on PATH). They refuse
to run as root, and CI runs as root: then they run as the `postgres` user, on a folder it
owns. The server listens on 127.0.0.1 and a Unix socket in that folder, trusts local
connections, and skips fsync (nothing here must survive a power cut), which makes it fast.
Each caller gets databases of its own (`create_database`); `stop()` removes everything.
"""

from __future__ import annotations

import glob
import os
import shutil
import socket
import subprocess
import tempfile
from pathlib import Path

BIN_GLOB = "/usr/lib/postgresql/*/bin"
SUPERUSER = "postgres"


def server_bin() -> Path | None:
    """The newest installed server's bin folder (`REGOLITH_PG_BIN` overrides), or None."""
    if override := os.environ.get("REGOLITH_PG_BIN"):
        return Path(override)
    found = [Path(p) for p in glob.glob(BIN_GLOB) if (Path(p) / "initdb").is_file()]
    found.sort(key=lambda p: int(p.parent.name) if p.parent.name.isdigit() else 0)
    if found:
        return found[-1]
    initdb = shutil.which("initdb")
    return Path(initdb).parent if initdb else None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class PgCluster:
    """One server; `url(name)` is a SQLAlchemy URL for database `name` on it."""

    def __init__(self, bindir: Path) -> None:
        self.bindir = bindir
        self.root = Path(tempfile.mkdtemp(prefix="regolith-pg-"))
        self.data = self.root / "data"
        self.port = _free_port()
        self._as_postgres = os.geteuid() == 0
        self._count = 0

    def _run(self, *cmd: str) -> None:
        full = [str(self.bindir / cmd[0]), *cmd[1:]]
        if self._as_postgres:
            full = ["runuser", "-u", SUPERUSER, "--", *full]
        done = subprocess.run(full, capture_output=True, text=True, timeout=120)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(full)} failed:\n{done.stdout}{done.stderr}")

    def start(self) -> PgCluster:
        if self._as_postgres:
            shutil.chown(self.root, user=SUPERUSER)
        self._run("initdb", "-D", str(self.data), "-A", "trust", "-U", SUPERUSER, "-E", "UTF8")
        options = (
            f"-p {self.port} -k {self.root} -c listen_addresses=127.0.0.1 "
            "-c fsync=off -c synchronous_commit=off -c full_page_writes=off "
            "-c max_connections=300"
        )
        log = str(self.root / "server.log")
        self._run("pg_ctl", "-D", str(self.data), "-l", log, "-o", options, "-w", "start")
        return self

    def stop(self) -> None:
        if (self.data / "postmaster.pid").exists():
            self._run("pg_ctl", "-D", str(self.data), "-m", "immediate", "-w", "stop")
        shutil.rmtree(self.root, ignore_errors=True)

    def url(self, database: str = SUPERUSER) -> str:
        return f"postgresql+psycopg://{SUPERUSER}@127.0.0.1:{self.port}/{database}"

    def create_database(self, prefix: str = "t") -> str:
        """A new, empty database; returns its URL."""
        import psycopg

        self._count += 1
        name = f"{prefix}_{self._count}"
        dsn = f"host=127.0.0.1 port={self.port} user={SUPERUSER} dbname={SUPERUSER}"
        with psycopg.connect(dsn, autocommit=True) as conn:
            conn.execute(f'CREATE DATABASE "{name}" TEMPLATE template0 STRATEGY FILE_COPY')
        return self.url(name)
