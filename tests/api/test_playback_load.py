"""Playback under load, against `regolith serve` in its own process (so its memory is its own).

Six finished missions, one live mission beside them (while a mission is live the heap is kept
frozen, `app/live/gc_pause.py`), then:

- six concurrent first scrubs: all answer, and every mission's checkpoint builder ends (a
  pool too small for everyone's checkpoints once made them evict and rebuild one another for
  ever); checked by the count of engines built, never by a clock;
- a burst of concurrent scrubs: the engines open never exceed the pool plus the replays in
  flight, the server's memory comes back near where it started (the engines are in the
  playback worker process, whose memory is bounded by its pool).
"""

from __future__ import annotations

import asyncio
import gc
import random
import time
import weakref
from pathlib import Path

import httpx
import psutil
import pytest

from app.live import gc_pause
from app.services.playback import WORKERS
from engine import reference_scenario
from tests import aio
from tests.api.conftest import AUTH
from tests.api.serve_process import ServeProcess

MISSIONS = 6
CAPACITY = 10  # REGOLITH_PLAYBACK_CURSORS's default
MB = 2**20
#: the server's memory after the burst, above its memory before it: the engines are in the
#: playback worker, so this is the requests' leftovers and the live mission's own growth
#: meanwhile (+16 MB measured after 500 scrubs; it was +200 MB with the engines in the server)
AFTER_BOUND_MB = 64
#: the playback worker's memory: its code (~60 MB), the pool (at most 13 engines of a few MB)
#: and the garbage of at most 4 closed ones (156 MB measured after 500 scrubs), generously
WORKER_BOUND_MB = 300


def _metric(api: httpx.Client, name: str) -> float:
    for line in api.get("/api/metrics").text.splitlines():
        if line.startswith(name + " "):
            return float(line.split()[1])
    raise AssertionError(f"{name} missing from /api/metrics")


def _until_builders_end(api: httpx.Client, most_built: int) -> None:
    """Wait while checkpoints are built, failing as soon as more engines were built than the
    requests and one round of checkpoints can need (evict-and-rebuild never ends)."""
    while _metric(api, "regolith_playback_checkpoint_builds") > 0:
        built = _metric(api, "regolith_playback_engines_built_total")
        assert built <= most_built, f"{built:.0f} engines built: checkpoints are thrashing"
        time.sleep(0.1)


async def _scrub_all(url: str, jobs: list[tuple[int, float]]) -> list[int]:
    limits = httpx.Limits(max_connections=len(jobs))
    async with httpx.AsyncClient(base_url=url, headers=AUTH, timeout=600, limits=limits) as c:

        async def one(mid: int, t: float) -> int:
            return (await c.get(f"/api/missions/{mid}/state", params={"t": t})).status_code

        return await asyncio.gather(*(one(m, t) for m, t in jobs))


@pytest.mark.sqlite_only  # the pool and the collector, whatever the database
def test_many_scrubs_beside_a_live_mission_stay_bounded(tmp_path: Path) -> None:
    with ServeProcess(tmp_path, REGOLITH_RATE_LIMIT_PER_S="0") as srv, srv.client() as api:
        ids = [
            api.post("/api/missions", json={"seed": s, "speed": "max"}).json()["id"]
            for s in range(MISSIONS)
        ]
        ends: dict[int, float] = {}
        while len(ends) < MISSIONS:
            for mid in ids:
                m = api.get(f"/api/missions/{mid}").json()
                if m["status"] not in ("running", "paused"):
                    ends[mid] = float(m["sim_time"])
            time.sleep(0.1)
        long = {**reference_scenario().model_dump(mode="json"), "minerals": 1500}
        long["max_time_s"] = 10_000_000
        live = api.post("/api/missions", json={"seed": 9, "speed": 20, "scenario": long}).json()
        assert srv.proc is not None
        server = psutil.Process(srv.proc.pid)

        # six first scrubs at once: all answer, and the checkpoint builders all end
        codes = aio.run(_scrub_all(srv.url, [(mid, 100.0) for mid in ids]))
        assert codes == [200] * MISSIONS
        _until_builders_end(api, most_built=MISSIONS + CAPACITY)
        assert _metric(api, "regolith_playback_engines") <= CAPACITY

        start = server.memory_info().rss
        rng = random.Random(5)
        jobs = [(mid, round(rng.random() * ends[mid], 1)) for mid in rng.choices(ids, k=80)]
        codes = aio.run(_scrub_all(srv.url, jobs))
        assert codes == [200] * len(jobs)
        built = _metric(api, "regolith_playback_engines_built_total")
        _until_builders_end(api, most_built=int(built) + CAPACITY)
        assert _metric(api, "regolith_playback_engines") <= CAPACITY + WORKERS
        assert api.get(f"/api/missions/{live['id']}").json()["status"] == "running"
        grown = (server.memory_info().rss - start) / MB
        assert grown < AFTER_BOUND_MB, f"{grown:.0f} MB kept after the burst"
        worker = _metric(api, "regolith_playback_worker_rss_bytes") / MB
        assert 0 < worker < WORKER_BOUND_MB, f"the playback worker holds {worker:.0f} MB"


class _Node:
    other: _Node


@pytest.mark.sqlite_only  # no server: once is enough
def test_cycles_frozen_with_the_heap_are_collected_once_it_doubles(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Objects in reference cycles, frozen with the heap while a mission was live, are freed
    by the full collection that runs once the frozen heap doubled (before that rule they
    stayed for the server's life)."""
    monkeypatch.setattr(gc_pause, "FLOOR", 0)
    pause = gc_pause.GcPause(every_s=0.0)
    try:
        nodes = []
        for _ in range(1000):
            a, b = _Node(), _Node()
            a.other, b.other = b, a
            nodes.append(a)
        ref = weakref.ref(nodes[0])
        pause.tick(busy=True)  # a mission is live: the heap is frozen, the cycles with it
        del nodes, a, b
        gc.collect()  # an ordinary collection never looks at frozen objects
        assert ref() is not None
        pause.tick(busy=True)  # the first freeze counted from nothing: the heap "doubled"
        assert ref() is None and pause.full == 1
        assert gc.get_freeze_count() > 0  # and the heap is frozen again
        pause.tick(busy=True)  # no growth since: no second full collection
        assert pause.full == 1
    finally:
        pause.stop()
