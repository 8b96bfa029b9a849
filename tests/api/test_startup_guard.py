"""What a server refuses to start on: a data folder another server holds, a damaged database.

Both refusals are one line on stderr and exit code 1 from `regolith serve` (and `regolith db
upgrade`), before anything is written; the server already running is untouched.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from sqlalchemy import create_engine, text
from sqlalchemy.pool import NullPool

from app.db.serverlock import LOCK_KEY, ServerLock
from app.startup import StartupRefused, preflight
from tests.api.conftest import TOKEN, LiveServer, database_for, make_settings, run_to_end
from tests.api.serve_process import ROOT, ServeProcess, free_port

PAGE = 4096


def _regolith(*args: str) -> subprocess.CompletedProcess[str]:
    """The real command line, to its end (a refused start ends at once)."""
    cmd = [sys.executable, "-c", "from app.cli import main; main()", *args]
    env = {**os.environ, "REGOLITH_TOKEN": TOKEN}
    return subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True, timeout=120)


def _db(data: Path) -> list[str]:
    """The data folder's database on the backend being run (none: SQLite in the folder)."""
    url = database_for(data)
    return ["--db", url] if url else []


def _serve(data: Path, *db: str) -> subprocess.CompletedProcess[str]:
    args = ("serve", "--port", str(free_port()), "--data-dir", str(data))
    return _regolith(*args, *(db or _db(data)))


def _one_line(result: subprocess.CompletedProcess[str], command: str, *says: str) -> str:
    assert result.returncode == 1, (result.returncode, result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"regolith {command}: ")
    for part in says:
        assert part in lines[0], lines[0]
    assert "Traceback" not in result.stderr
    return lines[0]


# the embedded server's refusal ends its thread with SystemExit(3), which pytest reports
EMBEDDED_REFUSAL = pytest.mark.filterwarnings(
    "ignore::pytest.PytestUnhandledThreadExceptionWarning"
)


@EMBEDDED_REFUSAL
def test_a_second_server_on_the_same_data_folder_refuses_to_start(tmp_path: Path) -> None:
    first = LiveServer(make_settings(tmp_path)).start()
    try:
        with first.client() as api:
            mid = api.post("/api/missions", json={"paused": True}).json()["id"]
            line = _one_line(_serve(tmp_path), "serve", str(tmp_path), "in use", str(os.getpid()))
            assert "another Regolith server" in line
            _one_line(
                _regolith("db", "upgrade", "--data-dir", str(tmp_path), *_db(tmp_path)),
                "db upgrade",
                "in use",
            )
            second = LiveServer(make_settings(tmp_path))
            with pytest.raises(RuntimeError):  # embedded (no CLI): the lifespan refuses too
                second.start()
            assert api.get("/api/health").status_code == 200
            assert api.get(f"/api/missions/{mid}").json()["status"] == "paused"
            assert api.post(f"/api/missions/{mid}/stop").status_code == 200
    finally:
        first.stop()
    with ServeProcess(tmp_path) as srv, srv.client() as api:  # the lock went with the first
        assert api.get(f"/api/missions/{mid}").json()["status"] == "stopped"


def _damage(db: Path) -> None:
    """Overwrite whole pages in the middle of the file (b-tree pages of the event table)."""
    pages = db.stat().st_size // PAGE
    assert pages > 20, pages
    with db.open("r+b") as f:
        for page in range(pages // 2, pages // 2 + 4):
            f.seek(page * PAGE)
            f.write(bytes([0xA5, 0x5A]) * (PAGE // 2))


@EMBEDDED_REFUSAL
@pytest.mark.postgresql_only
def test_a_second_server_on_the_same_postgresql_database_refuses_to_start(
    tmp_path: Path,
) -> None:
    """Another data folder, the same database: the database's advisory lock refuses it."""
    first = LiveServer(make_settings(tmp_path / "one")).start()
    url = database_for(tmp_path / "one")
    assert url is not None
    try:
        with first.client() as api:
            mid = api.post("/api/missions", json={"paused": True}).json()["id"]
            other = tmp_path / "two"
            line = _one_line(_serve(other, "--db", url), "serve", "in use", str(os.getpid()))
            assert "another Regolith server" in line and "advisory lock" in line
            upgrade = _regolith("db", "upgrade", "--data-dir", str(other), "--db", url)
            _one_line(upgrade, "db upgrade", "in use")
            second = LiveServer(make_settings(other, db_url=url))
            with pytest.raises(RuntimeError):  # embedded: the lifespan refuses too
                second.start()
            assert api.get(f"/api/missions/{mid}").json()["status"] == "paused"
    finally:
        first.stop()
    # the lock went with the first server's connection
    with ServeProcess(tmp_path / "two", "--db", url) as srv, srv.client() as api:
        assert api.get(f"/api/missions/{mid}").json()["status"] == "interrupted"
    gone = url.rsplit("/", 1)[0] + "/no_such_database"
    _one_line(_serve(tmp_path / "three", "--db", gone), "serve", "cannot connect", "no_such")


@pytest.mark.sqlite_only
def test_a_second_server_on_the_same_sqlite_file_refuses_whatever_its_data_folder(
    tmp_path: Path,
) -> None:
    """Another data folder whose --db names the first server's file (directly or through a
    symlink): refused by the lock beside the file; the first server's live mission goes on."""
    one = tmp_path / "one"
    with ServeProcess(one) as first, first.client() as api:
        mid = api.post("/api/missions", json={"speed": 1.0}).json()["id"]
        assert api.get(f"/api/missions/{mid}").json()["status"] == "running"
        db = one / "regolith.db"
        link = tmp_path / "elsewhere" / "link.db"
        link.parent.mkdir()
        link.symlink_to(db)
        for named in (db, link):
            url = f"sqlite:///{named}"
            line = _one_line(_serve(tmp_path / "two", "--db", url), "serve", "in use", str(db))
            assert f"pid {first.proc.pid if first.proc else ''}" in line
            assert "another Regolith server" in line and "--db" in line
            upgrade = _regolith("db", "upgrade", "--data-dir", str(tmp_path / "two"), "--db", url)
            _one_line(upgrade, "db upgrade", "in use", str(db))
        got = api.get(f"/api/missions/{mid}").json()
        assert got["status"] == "running", got
        log = first.stderr()
        assert "background write failed" not in log and "interrupted" not in log, log


@pytest.mark.sqlite_only
def test_a_database_that_cannot_be_locked_is_refused(tmp_path: Path) -> None:
    """Neither a file to lock beside nor an advisory lock: refused, not shared unguarded."""
    settings = make_settings(tmp_path, db_url="mysql://u:secret@localhost/x")
    with pytest.raises(StartupRefused, match="no way to lock") as refused:
        preflight(settings)
    assert "secret" not in str(refused.value)
    preflight(make_settings(tmp_path)).release()  # the folder's lock was not left behind


@EMBEDDED_REFUSAL
@pytest.mark.sqlite_only
def test_a_damaged_database_is_refused_with_what_is_wrong(tmp_path: Path) -> None:
    good = tmp_path / "good"
    server = LiveServer(make_settings(good)).start()
    try:
        with server.client() as api:
            mid = api.post("/api/missions", json={"seed": 3, "speed": "max"}).json()["id"]
            run_to_end(api, mid)
    finally:
        server.stop()
    bad = tmp_path / "bad"
    bad.mkdir()
    shutil.copy(good / "regolith.db", bad / "regolith.db")
    _damage(bad / "regolith.db")
    db = str(bad / "regolith.db")
    line = _one_line(_serve(bad), "serve", db, "is damaged", "quick_check")
    assert "backup" in line and "Page " in line  # the first problems, by page
    _one_line(_regolith("db", "upgrade", "--data-dir", str(bad)), "db upgrade", db, "is damaged")
    with pytest.raises(RuntimeError):  # embedded (no CLI): the lifespan refuses too
        LiveServer(make_settings(bad)).start()
    # the intact original still starts
    with ServeProcess(good) as srv, srv.client() as api:
        assert api.get(f"/api/missions/{mid}").json()["status"] == "completed"


@pytest.mark.sqlite_only
def test_a_file_that_is_not_a_database_is_refused(tmp_path: Path) -> None:
    (tmp_path / "regolith.db").write_bytes(b"this is not SQLite" * 1000)
    _one_line(_serve(tmp_path), "serve", "is damaged", "not a database")


@pytest.mark.postgresql_only
def test_a_released_advisory_lock_is_free_at_once(tmp_path: Path) -> None:
    """A server restarted at once must find the database free. Closing the lock's connection
    left the lock held until PostgreSQL's backend had exited, after the close returned: a
    quick restart (the API suite's, on a quiet machine) was refused as "in use by another
    Regolith server". Here the next server's connection is open before the release, so the
    lock is asked for the instant `release` returns."""
    url = database_for(tmp_path / "one")
    assert url is not None
    engine = create_engine(url, poolclass=NullPool)
    try:
        for _ in range(50):
            lock = ServerLock(url).acquire()
            with engine.connect() as conn:
                conn.execute(text("select 1"))  # connected: its backend is up
                lock.release()
                assert conn.scalar(text("select pg_try_advisory_lock(:k)"), {"k": LOCK_KEY})
                conn.scalar(text("select pg_advisory_unlock(:k)"), {"k": LOCK_KEY})
    finally:
        engine.dispose()
