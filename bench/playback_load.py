"""Playback under load: the server's memory and the checkpoint builders with many scrubs.

    .venv/bin/python bench/playback_load.py [--missions 6] [--scrubs 500] [--scale 1] [--diag]

Starts `regolith serve` in a subprocess on a free port with a fresh data folder, runs
`--missions` missions to their end at "max", then starts one long live mission at 20x (it
stays live throughout: the heap is frozen, `app/live/gc_pause.py`) and measures

1. first: one concurrent first scrub (`state?t=100`) on each finished mission, then how long
   until every mission's checkpoint builder has finished (`regolith_playback_checkpoint_builds`
   back to 0 in `/api/metrics`) and the server's CPU share meanwhile;
2. load: `--scrubs` concurrent scrubs to random times over those missions (all sent at once);
   the server's resident memory (RSS) sampled every 0.1 s: at start, peak, and 10 s after the
   last answer; the engines open (`regolith_playback_engines`) and full collections run;
   the playback worker's RSS (the server's child process) at its peak and 10 s after;
3. idle: how long until the server stops the idle worker (`--idle`, REGOLITH_PLAYBACK_IDLE_S),
   and the server's RSS then.

Prints one line per figure. With `--diag` the server runs under bench/memdiag_serve.py and
the memory's make-up (glibc heap, CPython's allocator arenas and blocks, objects by type) is
printed before playback, before the load and 10 s after it, then once more after closing the
pool's engines with a full collection and `malloc_trim` (what stays without them).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import os
import random
import signal
import subprocess
import tempfile
import threading
import time
from pathlib import Path

import httpx
import psutil
from service_bench import AUTH, LONG, free_port, pct, start_server  # bench/, beside this script

from engine import reference_scenario

MB = 2**20


def metric(api: httpx.Client, name: str) -> float:
    """One unlabelled sample of `/api/metrics`."""
    for line in api.get("/api/metrics").text.splitlines():
        if line.startswith(name + " "):
            return float(line.split()[1])
    raise KeyError(name)


def gauge(api: httpx.Client, name: str) -> str:
    try:
        return f"{metric(api, name):.0f}"
    except KeyError:
        return "?"


def children_rss(proc: psutil.Process) -> int:
    """The RSS of the server's child processes (the playback worker), summed."""
    total = 0
    for child in proc.children(recursive=True):
        with contextlib.suppress(psutil.Error):
            total += child.memory_info().rss
    return total


class Sampler(threading.Thread):
    """The server's RSS and its children's (the playback worker) every 0.1 s, keeping peaks."""

    def __init__(self, proc: psutil.Process) -> None:
        super().__init__(daemon=True)
        self.proc, self.peak, self.stop = proc, 0, threading.Event()
        self.child_peak = 0

    def run(self) -> None:
        while not self.stop.wait(0.1):
            self.peak = max(self.peak, self.proc.memory_info().rss)
            self.child_peak = max(self.child_peak, children_rss(self.proc))


def finished(api: httpx.Client, n: int, scale: int) -> list[int]:
    scenario = reference_scenario().scaled(scale).model_dump(mode="json")
    ids = [
        api.post("/api/missions", json={"seed": s, "speed": "max", "scenario": scenario}).json()[
            "id"
        ]
        for s in range(n)
    ]
    for mid in ids:
        while api.get(f"/api/missions/{mid}").json()["status"] in ("running", "paused"):
            time.sleep(0.2)
    return ids


async def scrubs(base: str, ends: dict[int, float], n: int, seed: int) -> list[float]:
    rng = random.Random(seed)
    jobs = [(rng.choice(list(ends)), rng.random()) for _ in range(n)]
    limits = httpx.Limits(max_connections=n)
    async with httpx.AsyncClient(base_url=base, headers=AUTH, timeout=900, limits=limits) as c:

        async def one(mid: int, u: float) -> float:
            t0 = time.perf_counter()
            r = await c.get(f"/api/missions/{mid}/state", params={"t": round(u * ends[mid], 3)})
            r.raise_for_status()
            return time.perf_counter() - t0

        return await asyncio.gather(*(one(m, u) for m, u in jobs))


def settle(api: httpx.Client, server: psutil.Process, cap: float = 180.0) -> float:
    """Wait until no checkpoint is being built; the seconds it took (inf: still building
    after `cap`). A server without the gauge (an older build): until its CPU share over a
    second falls under 30 % (the live mission alone uses less)."""
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < cap:
        try:
            if metric(api, "regolith_playback_checkpoint_builds") == 0:
                return time.perf_counter() - t0
            time.sleep(0.2)
        except KeyError:
            if server.cpu_percent(interval=1.0) < 30:
                return time.perf_counter() - t0
    return float("inf")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--missions", type=int, default=6)
    ap.add_argument("--scrubs", type=int, default=500)
    ap.add_argument("--scale", type=int, default=1)
    ap.add_argument("--diag", action="store_true", help="memory make-up (memdiag_serve.py)")
    ap.add_argument("--idle", type=float, default=20.0, help="REGOLITH_PLAYBACK_IDLE_S")
    args = ap.parse_args()
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "memdiag.txt"
        launcher = [str(Path(__file__).with_name("memdiag_serve.py"))] if args.diag else None
        proc = start_server(
            Path(tmp),
            port,
            {"MEMDIAG_OUT": str(out), "REGOLITH_PLAYBACK_IDLE_S": str(args.idle)},
            launcher,
        )
        server = psutil.Process(proc.pid)

        def diag(sig: signal.Signals = signal.SIGUSR1) -> None:
            """Ask the server for its memory's make-up; wait until it is written."""
            if args.diag:
                size = out.stat().st_size if out.exists() else 0
                proc.send_signal(sig)
                while not out.exists() or out.stat().st_size == size:
                    time.sleep(0.2)

        try:
            with httpx.Client(base_url=base, headers=AUTH, timeout=900) as api:
                ids = finished(api, args.missions, args.scale)
                ends = {m: float(api.get(f"/api/missions/{m}").json()["sim_time"]) for m in ids}
                live = api.post(
                    "/api/missions", json={"seed": 99, "speed": 20, "scenario": LONG}
                ).json()
                print(f"{len(ids)} finished missions (scale {args.scale}), one live at 20x")
                time.sleep(2.0)
                diag()
                rss0 = server.memory_info().rss
                cpu0, t0 = sum(server.cpu_times()[:2]), time.perf_counter()
                first = asyncio.run(_firsts(base, ids))
                took = settle(api, server)
                cpu = (sum(server.cpu_times()[:2]) - cpu0) / (time.perf_counter() - t0)
                print(
                    f"first: {len(ids)} concurrent first scrubs answered in {max(first):.2f} s; "
                    f"checkpoints finished {took:.1f} s later; server CPU {cpu:.0%} of a core; "
                    f"engines open {gauge(api, 'regolith_playback_engines')}"
                )
                diag()
                sampler = Sampler(server)
                sampler.start()
                start = server.memory_info().rss
                lat = asyncio.run(scrubs(base, ends, args.scrubs, 1))
                took = settle(api, server)
                time.sleep(10.0)
                sampler.stop.set()
                after = server.memory_info().rss
                worker_after = children_rss(server)
                state = api.get(f"/api/missions/{live['id']}").json()["status"]
                print(
                    f"load: {args.scrubs} concurrent scrubs, p50 {pct(lat, 0.5):.2f} s, "
                    f"max {max(lat):.2f} s; checkpoints finished {took:.1f} s after the last"
                )
                print(
                    f"memory: {rss0 / MB:.0f} MB before playback, {start / MB:.0f} MB before the "
                    f"load, peak {sampler.peak / MB:.0f} MB, {after / MB:.0f} MB 10 s after; "
                    f"engines open {gauge(api, 'regolith_playback_engines')}, built "
                    f"{gauge(api, 'regolith_playback_engines_built_total')}, full "
                    f"collections {gauge(api, 'regolith_gc_full_collections_total')} taking "
                    f"{gauge(api, 'regolith_gc_full_collection_seconds_total')} s; "
                    f"live mission {state}"
                )
                print(
                    f"playback worker: peak {sampler.child_peak / MB:.0f} MB, "
                    f"{worker_after / MB:.0f} MB 10 s after"
                )
                t1 = time.perf_counter()
                while metric(api, "regolith_playback_worker_up") > 0:
                    time.sleep(0.5)
                time.sleep(2.0)
                print(
                    f"idle: worker stopped {time.perf_counter() - t1 + 10:.0f} s after the last "
                    f"answer (--idle {args.idle:g}); server {server.memory_info().rss / MB:.0f} MB "
                    f"2 s later, children {children_rss(server) / MB:.0f} MB; load average "
                    + " ".join(f"{x:.1f}" for x in os.getloadavg())
                )
                diag()
                diag(signal.SIGHUP)
                if args.diag:
                    print(out.read_text(), end="")
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()


async def _firsts(base: str, ids: list[int]) -> list[float]:
    async with httpx.AsyncClient(base_url=base, headers=AUTH, timeout=900) as c:

        async def one(mid: int) -> float:
            t0 = time.perf_counter()
            (await c.get(f"/api/missions/{mid}/state", params={"t": 100})).raise_for_status()
            return time.perf_counter() - t0

        return await asyncio.gather(*(one(m) for m in ids))


if __name__ == "__main__":
    main()
