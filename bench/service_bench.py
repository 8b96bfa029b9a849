"""Service benchmark: live-stream fan-out and control-call latency against a real server.

    .venv/bin/python bench/service_bench.py [--viewers 100] [--seconds 15] [--calls 300]
    .venv/bin/python bench/service_bench.py --stalled [--phases stalled]

Starts `regolith serve` in a subprocess on a free port with a fresh data folder, then

1. viewers: N WebSocket viewers of one mission running at 10x, at the full frame rate;
   frame delay = client receive time - the frame's `wall` stamp (same machine clock);
   server CPU = the server process's CPU time / wall time over the window;
2. control: three missions at "max" speed while an operator makes sequential control calls
   (policy switches and speed changes on the running missions, pause/resume of a fourth);
   latency = full HTTP round trip as the client sees it;
3. stalled (`--stalled`): ten reading viewers of one long mission at 200x, three windows:
   clean, with an eleventh viewer that never reads (a raw socket that stops after the
   handshake with 536-byte segments, so the server's sends to it block within ~2 s and its
   queue grows), and clean again after the server dropped it (a spell at "max" fills its
   queue); then a control run of the same mission without it, with the same waits. Frame
   delay as in 1; the mission's pace from the frames' (wall, t) stamps.

Targets (the service's): p99 frame delay < 100 ms; control p99 < 50 ms. A slow client: the readers'
frame delay with the stalled viewer within 2x of the clean windows, the pace unchanged.
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
from dataclasses import dataclass
from pathlib import Path

import httpx
import psutil
import websockets
from slow_viewer import gauge, stalled_viewer  # bench/, beside this script

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


def start_server(
    data_dir: Path,
    port: int,
    extra_env: dict[str, str] | None = None,
    launcher: list[str] | None = None,
) -> subprocess.Popen[bytes]:
    """`regolith serve` with the bench token and no rate limit (each bench's phases are
    deliberate bursts), plus `extra_env`; returns once it answers. `launcher`: a script
    that runs the CLI instead (bench/memdiag_serve.py)."""
    env = {**os.environ, "REGOLITH_TOKEN": TOKEN, "REGOLITH_RATE_LIMIT_PER_S": "0"}
    env.update(extra_env or {})
    cmd = [sys.executable, *(launcher or ["-c", "from app.cli import main; main()"]), "serve"]
    cmd += ["--port", str(port), "--data-dir", str(data_dir), "--log-level", "warning"]
    proc = subprocess.Popen(cmd, env=env, cwd=ROOT, stdout=subprocess.DEVNULL)
    deadline = time.monotonic() + 300  # a loaded machine takes a minute and more to import
    while time.monotonic() < deadline and proc.poll() is None:
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
        for m in [*running, spare]:  # leave the machine quiet for the next phase
            api.post(f"/api/missions/{m}/stop")
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


STALL_SPEED, STALL_READERS, STALL_QUEUE = 200.0, 10, 8_000
FRAME_PREFIX = '{"type":"frame",'


@dataclass
class Window:
    """Ten readers over one window: frame delays (ms), frames/s per reader, pace, gauges."""

    delays: list[float]
    per_reader: float
    rate: float
    viewers: list[int]
    backlog: list[int]
    flood_s: float  # seconds at "max" just before it (0 for the first window)


async def stalled_session(
    base: str, port: int, seconds: float, floods: list[float] | None
) -> list[Window]:
    """Three windows of ten readers on a fresh mission (same seed each call), each but the
    first after a wait. With `floods=None` an eleventh viewer that never reads joins after
    the first window; the waits last until its sends block (at the bench speed) and until it
    is dropped (at "max", which fills its queue). Otherwise there is no stalled viewer and the
    waits last `floods` seconds, so a control run reaches the same points of the mission."""
    api = httpx.AsyncClient(base_url=base, headers=AUTH, timeout=30)
    scenario = {**LONG, "minerals": 20_000}  # never finishes, even at "max"
    body = {"seed": 8, "speed": STALL_SPEED, "paused": True, "scenario": scenario}
    mid = (await api.post("/api/missions", json=body)).json()["id"]
    url = f"ws://127.0.0.1:{port}/api/missions/{mid}/live"
    seen: list[tuple[int, float, float, float]] = []

    async def read(ws: websockets.ClientConnection, reader: int) -> None:
        async for raw in ws:
            if isinstance(raw, str) and raw.startswith(FRAME_PREFIX):
                now, frame = time.time(), json.loads(raw)
                seen.append((reader, frame["wall"], frame["t"], (now - frame["wall"]) * 1000))

    async def gauges() -> tuple[int, int]:
        text = (await api.get("/api/metrics")).text
        return gauge(text, "regolith_viewers", mid), gauge(text, "regolith_viewer_backlog", mid)

    async def flat_out(stop: str | float, speed: str = "max") -> float:
        t0 = time.monotonic()
        await api.put(f"/api/missions/{mid}/speed", json={"speed": speed})
        while True:
            if isinstance(stop, float):
                await asyncio.sleep(stop)
                break
            viewers, backlog = await gauges()
            if (stop == "blocked" and backlog > 50) or (stop == "dropped" and viewers == 10):
                break
            if time.monotonic() - t0 > 120:
                raise SystemExit(f"the stalled viewer was never {stop}")
            await asyncio.sleep(0.05)
        await api.put(f"/api/missions/{mid}/speed", json={"speed": STALL_SPEED})
        took = time.monotonic() - t0
        await asyncio.sleep(0.5)
        return took

    async def window(flood_s: float) -> Window:
        start, samples = time.time(), []
        for _ in range(int(seconds)):
            await asyncio.sleep(1.0)
            samples.append(await gauges())
        end = time.time()
        mine = [x for x in seen if start <= x[1] < end]
        ticks = [(w, t) for r, w, t, _ in mine if r == 0]
        rate = (ticks[-1][1] - ticks[0][1]) / (ticks[-1][0] - ticks[0][0])
        per_reader = len(mine) / STALL_READERS / (end - start)
        viewers, backlog = [v for v, _ in samples], [b for _, b in samples]
        return Window([d for *_, d in mine], per_reader, rate, viewers, backlog, flood_s)

    sockets = [await websockets.connect(url, max_size=2**24) for _ in range(STALL_READERS)]
    for ws in sockets:
        await ws.recv()  # the snapshot
    tasks = [asyncio.create_task(read(ws, i)) for i, ws in enumerate(sockets)]
    await api.post(f"/api/missions/{mid}/resume")
    await asyncio.sleep(1.0)
    out = [await window(0.0)]
    if floods is None:
        stall = await asyncio.to_thread(stalled_viewer, port, mid)
        out.append(await window(await flat_out("blocked", STALL_SPEED)))  # within ~2 s
        out.append(await window(await flat_out("dropped")))
        stall.close()
    else:
        out.append(await window(await flat_out(floods[0], STALL_SPEED)))
        out.append(await window(await flat_out(floods[1])))
    await asyncio.gather(*(ws.close() for ws in sockets))  # readers keep draining meanwhile
    await asyncio.gather(*tasks)
    await api.post(f"/api/missions/{mid}/stop")
    await api.aclose()
    return out


def bench_stalled(base: str, port: int, seconds: float) -> None:
    stalled = asyncio.run(stalled_session(base, port, seconds, None))
    control = asyncio.run(stalled_session(base, port, seconds, [w.flood_s for w in stalled[1:]]))
    print(
        f"stalled: {STALL_READERS} reading viewers of one mission at {STALL_SPEED:g}x "
        f"(10 frames/s), three {seconds:.0f} s windows, with and without an eleventh viewer "
        "that never reads (control: same seed, same waits)"
    )
    names = ("before", "stalled viewer attached", "after it was dropped")
    for name, w, c in zip(names, stalled, control, strict=True):
        spell = f"after a {w.flood_s:.1f} s wait; " if w.flood_s else ""
        print(
            f"  {name} ({spell}viewers {sorted(set(w.viewers))};"
            f" stalled viewer's backlog {w.backlog[0]} -> {w.backlog[-1]})"
        )
        for label, x in (("stall run", w), ("control", c)):
            print(
                f"    {label:10s} frame delay p50 {pct(x.delays, 0.5):5.1f} ms"
                f"  p99 {pct(x.delays, 0.99):6.1f} ms  {x.per_reader:4.1f} frames/s per reader"
                f"  {x.rate:4.0f} sim s per wall s"
            )
    w, c = stalled[1], control[1]
    print(
        f"  stalled window vs control: p50 {pct(w.delays, 0.5) / pct(c.delays, 0.5):.2f}x"
        f"  p99 {pct(w.delays, 0.99) / pct(c.delays, 0.99):.2f}x  pace {w.rate / c.rate:.3f}x"
    )
    before, after = stalled[0], stalled[2]
    references = {
        "the control run's window": (c.delays, c.per_reader, c.rate),
        "the clean windows around it": (
            before.delays + after.delays,
            (before.per_reader + after.per_reader) / 2,
            (before.rate + after.rate) / 2,
        ),
    }
    for name, (delays, per_reader, rate) in references.items():
        held = slow_client_bound(w, delays, per_reader, rate)
        print(f"  slow-client bound against {name}: {'held' if held else 'NOT HELD'}")


def slow_client_bound(w: Window, delays: list[float], per_reader: float, rate: float) -> bool:
    """With the stalled viewer attached, the readers' median frame delay within 2x of the
    reference's plus 20 ms (a few ms move by more than 2x from scheduling alone on a loaded
    2-core machine; p99 is printed, never judged), at least half its frames per reader, and
    the mission's pace within 10% of the reference's (or of the asked speed)."""
    return (
        pct(w.delays, 0.5) <= 2 * pct(delays, 0.5) + 20
        and w.per_reader >= 0.5 * per_reader
        and w.rate >= 0.9 * min(rate, STALL_SPEED)
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--viewers", type=int, default=100)
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--calls", type=int, default=300)
    parser.add_argument(
        "--phases", default="viewers,control", help="comma-separated: viewers,control,stalled"
    )
    parser.add_argument("--stalled", action="store_true", help="add the stalled-viewer phase")
    parser.add_argument("--stall-seconds", type=float, default=8.0, help="each stalled window")
    args = parser.parse_args()
    phases = args.phases.split(",") + (["stalled"] if args.stalled else [])
    port = free_port()
    with tempfile.TemporaryDirectory() as tmp:
        # many viewers, and a stalled viewer that lasts its window
        viewers = {"REGOLITH_MAX_VIEWERS": "1000", "REGOLITH_VIEWER_QUEUE": str(STALL_QUEUE)}
        server = start_server(Path(tmp), port, viewers)
        try:
            proc = psutil.Process(server.pid)
            base = f"http://127.0.0.1:{port}"
            print(f"machine: {os.cpu_count()} cores, Python {sys.version.split()[0]}")
            if "viewers" in phases:
                bench_viewers(base, port, proc, args.viewers, args.seconds)
            if "control" in phases:
                bench_control(base, args.calls)
            if "stalled" in phases:
                bench_stalled(base, port, args.stall_seconds)
        finally:
            server.terminate()
            server.wait(timeout=30)


if __name__ == "__main__":
    main()
