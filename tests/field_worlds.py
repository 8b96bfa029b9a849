"""A test leaves no field mission running. A server that stops leaves its field missions'
world services and robots mining, by design (docs/field.md, "Processes"); a test server's
teardown ends them here, from what its database says of them (`field_links`)."""

from __future__ import annotations

import contextlib
import os
import signal
import time
from pathlib import Path

from sqlalchemy import select

from app.db.models import FieldLink, Mission
from app.db.session import make_engine

STOP_S = 20.0
LIVE = ("running", "paused")


def _gone(pid: int) -> bool:
    """Ended (a zombie counts: ended, not yet reaped by its parent)."""
    try:
        os.kill(pid, 0)
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] == "Z"
    except (ProcessLookupError, OSError, IndexError):
        return True


def _is_world(pid: int) -> bool:
    try:
        return b"field.world_process" in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


def end_field_worlds(database_url: str) -> None:
    """SIGTERM the world process of every field mission stored in this database (it stops
    its agents and ends), SIGKILL what is left after `STOP_S`."""
    engine = make_engine(database_url)
    try:
        with engine.connect() as con:
            pids = [
                int(pid)
                for (pid,) in con.execute(
                    select(FieldLink.world_pid)
                    .join(Mission, Mission.id == FieldLink.mission_id)
                    .where(FieldLink.world_pid.is_not(None), Mission.status.in_(LIVE))
                )
                if _is_world(int(pid))  # (a pid the system gave to another process since)
            ]
    except Exception:  # no such table (an older database) or no database: nothing started
        return
    finally:
        engine.dispose()
    for pid in pids:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + STOP_S
    for pid in pids:
        while not _gone(pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        if not _gone(pid):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pid, signal.SIGKILL)
