"""Service benchmark: live-stream fan-out and control-call latency against a real server.

    .venv/bin/python bench/service_bench.py [--viewers 100] [--seconds 15] [--calls 300]

Starts `regolith serve` in a subprocess on a free port with a fresh data folder, then

1. viewers: N WebSocket viewers of one mission running at 10x, at the full frame rate;
   frame delay = client receive time - the frame's `wall` stamp (same machine clock);
   server CPU = the server process's CPU time / wall time over the window;
2. control: three missions at "max" speed while an operator makes sequential control calls
   (policy switches and speed changes on the running missions, pause/resume of a fourth);
   latency = full HTTP round trip as the client sees it.

Targets (issue 4): p99 frame delay < 100 ms; control p99 < 50 ms.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx
import psutil
import websockets

TOKEN = "bench-operator-token-0123456789"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
ROOT = Path(__file__).resolve().parent.parent
# A long mission for the control phase: many more minerals on the reference map keep the
# engine busy at "max"; a mission that still finishes is replaced by a fresh one.
LONG = {"minerals": 1500, "max_time_s": 10_000_000}


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_server(data_dir: Path, port: int) -> subprocess.Popen[bytes]:
    env = {**os.environ, "REGOLITH_TOKEN": TOKEN, "REGOLITH_MAX_VIEWERS": "1000"}
    env["REGOLITH_RATE_LIMIT_PER_S"] = "0"  # the control phase is a deliberate burst
    cmd = [sys.executable, "-c", "from app.cli import main; main()", "serve"]
    cmd += ["--port", str(port), "--data-dir", str(data_dir), "--log-level", "warning"]
    proc = subprocess.Popen(cmd, env=env, cwd=ROOT, stdout=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/api/health").status_code == 200:
                return proc
        except httpx.TransportError:
            time.sleep(0.1)
    proc.kill()
    raise SystemExit("server did not start")


async def viewer(url: str, until: float, delays: list[float], counts: list[int]) -> None:
    async with websockets.connect(url, max_size=2**24) as ws:
        n = 0
        while True:
            left = until - time.time()
            if left <= 0:
                break
            try:
                raw = await asyncio.wait_for(ws.recv(), timeout=left)
            except TimeoutError:
                break
            now = time.time()
            msg = json.loads(raw)
            if msg["type"] == "frame":
                delays.append(now - msg["wall"])
                n += 1
        counts.append(n)


def bench_viewers(base: str, port: int, proc: psutil.Process, n: int, seconds: float) -> None:
    with httpx.Client(base_url=base, headers=AUTH, timeout=30) as api:
        mid = api.post("/api/missions", json={"seed": 1, "speed": 10}).json()["id"]
    url = f"ws://127.0.0.1:{port}/api/missions/{mid}/live"
    delays: list[float] = []
    counts: list[int] = []

    async def run() -> tuple[float, float]:
        start = time.time() + 1.0  # connect everyone, then measure a steady window
        tasks = [
            asyncio.create_task(viewer(url, start + seconds, delays, counts)) for _ in range(n)
        ]
        await asyncio.sleep(max(0.0, start - time.time()))
        delays.clear()
        cpu0, t0 = sum(proc.cpu_times()[:2]), time.monotonic()
        await asyncio.gather(*tasks)
        return sum(proc.cpu_times()[:2]) - cpu0, time.monotonic() - t0

    cpu, wall = asyncio.run(run())
    ms = [d * 1000 for d in delays]
    rate = statistics.mean(counts) / (seconds + 1.0)
    print(f"viewers: {n} WebSocket viewers of one mission at 10x, {seconds:.0f} s window")
    print(f"  frames received: {len(ms)} ({rate:.1f}/s per viewer; server rate 10/s)")
    print(
        f"  frame delay p50 {pct(ms, 0.5):.1f} ms  p99 {pct(ms, 0.99):.1f} ms  max {max(ms):.1f} ms"
    )
    print(f"  server CPU {100 * cpu / wall:.0f}% of one core")


def bench_control(base: str, calls: int) -> None:
    with httpx.Client(base_url=base, headers=AUTH, timeout=30) as api:

        def flat_out(seed: int) -> int:
            body = {"seed": seed, "speed": "max", "scenario": LONG}
            mission_id: int = api.post("/api/missions", json=body).json()["id"]
            return mission_id

        running = [flat_out(s) for s in (1, 2, 3)]
        replaced = 0
        spare = api.post("/api/missions", json={"seed": 4, "paused": True}).json()["id"]
        time.sleep(1.0)
        t_sim0 = {m: api.get(f"/api/missions/{m}").json()["sim_time"] for m in running}
        t0 = time.monotonic()
        lat: dict[str, list[float]] = {"policy": [], "speed": [], "pause/resume": []}
        policies = ["nearest", "fcfs"]
        for i in range(calls):
            kind = ("policy", "speed", "pause/resume")[i % 3]
            mid = running[i % 3]
            start = time.perf_counter()
            if kind == "policy":
                r = api.put(f"/api/missions/{mid}/policy", json={"policy": policies[i % 2]})
            elif kind == "speed":
                r = api.put(f"/api/missions/{mid}/speed", json={"speed": "max"})
            else:
                r = api.post(f"/api/missions/{spare}/{'pause' if i % 2 else 'resume'}")
            if r.status_code == 409:  # that mission finished: keep three running
                running[i % 3] = flat_out(10 + i)
                replaced += 1
                continue
            r.raise_for_status()
            lat[kind].append((time.perf_counter() - start) * 1000)
            time.sleep(0.02)
        wall = time.monotonic() - t0
        after = {m: api.get(f"/api/missions/{m}").json() for m in running}
        busy = sum(1 for m in after.values() if m["status"] == "running")
    everything = [x for v in lat.values() for x in v]
    print(f"control: {calls} sequential calls while 3 missions run at max speed")
    print(f"  ({replaced} finished missions replaced; {busy} still running at the end)")
    print(f"  all calls p50 {pct(everything, 0.5):.1f} ms  p99 {pct(everything, 0.99):.1f} ms")
    for kind, values in lat.items():
        print(f"  {kind:13s} p50 {pct(values, 0.5):.1f} ms  p99 {pct(values, 0.99):.1f} ms")
    for m, rec in after.items():
        if m in t_sim0:
            rate = (rec["sim_time"] - t_sim0[m]) / wall
            print(f"  mission {m}: {rec['status']}, {rate:.0f} simulated s per wall s meanwhile")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--viewers", type=int, default=100)
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--calls", type=int, default=300)
    args = parser.parse_args()
    port = free_port()
    with tempfile.TemporaryDirectory() as tmp:
        server = start_server(Path(tmp), port)
        try:
            proc = psutil.Process(server.pid)
            base = f"http://127.0.0.1:{port}"
            print(f"machine: {os.cpu_count()} cores, Python {sys.version.split()[0]}")
            bench_viewers(base, port, proc, args.viewers, args.seconds)
            bench_control(base, args.calls)
        finally:
            server.terminate()
            server.wait(timeout=30)


if __name__ == "__main__":
    main()
