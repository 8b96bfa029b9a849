"""`kill -9` of the server mid-sweep: its worker processes die with it (they used to run on,
135 MB each, for as long as their runs took) and the next server starts on the same folder."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from tests.api.conftest import wait_for
from tests.api.serve_process import ServeProcess
from tests.progress import STALL_S, START_S


def _children() -> dict[int, list[int]]:
    """Every process's children, from /proc."""
    tree: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:  # ended meanwhile
            continue
        ppid = int(stat.rpartition(")")[2].split()[1])
        tree.setdefault(ppid, []).append(int(entry.name))
    return tree


def _descendants(pid: int) -> dict[int, int]:
    """pid → depth below `pid` (1 = child)."""
    tree, found, todo = _children(), {}, [(pid, 0)]
    while todo:
        parent, depth = todo.pop()
        for child in tree.get(parent, []):
            found[child] = depth + 1
            todo.append((child, depth + 1))
    return found


def _running(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rpartition(")")[2].split()[0] != "Z"  # a zombie holds no memory


@pytest.mark.sqlite_only  # worker processes, whatever the database
def test_sweep_workers_die_with_a_killed_server(tmp_path: Path) -> None:
    with ServeProcess(tmp_path, "--log-level", "warning", REGOLITH_SWEEP_WORKERS="2") as srv:
        assert srv.proc is not None
        with srv.client() as api:
            res = api.post("/api/sweeps", json={"policies": [1], "seeds": "0-99"})
            assert res.status_code == 202, res.text
            sid = res.json()["id"]
        pid = srv.proc.pid

        def workers() -> list[int] | None:
            """Both workers: grandchildren (forked by the fork server, the server's child)."""
            found = [p for p, depth in _descendants(pid).items() if depth >= 2]
            return found if len(found) >= 2 else None

        workers_seen = wait_for(workers, timeout=START_S)  # processes starting
        family = _descendants(pid)
        assert all(_running(p) for p in workers_seen)
        os.kill(pid, signal.SIGKILL)
        srv.proc.wait(timeout=30)
        wait_for(lambda: not any(_running(p) for p in family), timeout=STALL_S, every=0.1)

    with ServeProcess(tmp_path, "--log-level", "warning") as again, again.client() as api:
        assert api.get(f"/api/sweeps/{sid}").json()["status"] == "interrupted"
