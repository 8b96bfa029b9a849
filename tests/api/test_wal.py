"""The SQLite write-ahead log stays small: a mission at "max" writes without pause, and the
log used to grow through the whole run and keep its size afterwards."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from tests.api.conftest import LiveServer, make_settings, run_to_end, wait_for
from tests.progress import STALL_S

MB = 1024 * 1024


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except FileNotFoundError:
        return 0


@pytest.mark.sqlite_only
def test_the_wal_is_truncated_during_and_after_a_mission_at_max_speed(tmp_path: Path) -> None:
    server = LiveServer(make_settings(tmp_path)).start()
    wal = tmp_path / "regolith.db-wal"
    sizes: list[int] = []
    done = threading.Event()

    def sample() -> None:
        while not done.wait(0.05):
            sizes.append(_size(wal))

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    try:
        with server.client() as api:
            events = 0
            for seed in (1, 2, 3):
                mid = api.post("/api/missions", json={"seed": seed, "speed": "max"}).json()["id"]
                assert run_to_end(api, mid)["status"] == "completed"
                page = api.get(f"/api/missions/{mid}/events", params={"limit": 1}).json()
                events += page["total"]
            assert events > 10_000
            # idle now: the next checkpoint empties the log
            wait_for(lambda: _size(wal) == 0, timeout=STALL_S)
        done.set()
        sampler.join()
        db = _size(tmp_path / "regolith.db")
        print(f"db {db / MB:.1f} MB, largest WAL seen {max(sizes) / MB:.1f} MB")
        assert max(sizes) < 24 * MB  # 8 MB threshold plus a second of writes at "max"
    finally:
        done.set()
        server.stop()
