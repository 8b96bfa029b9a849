"""Playback benchmark: how long a scrub takes (`GET /api/missions/{id}/state?t=`).

    .venv/bin/python bench/playback_bench.py [--scale 1] [--seed 4] [--steps 100] [--per-mission 5]

`--per-mission 1` leaves out the checkpoints (one cursor per mission): the A/B comparison.

Starts `regolith serve` in a subprocess on a free port with a fresh data folder, runs one
mission to its end at "max" (with an abrupt failure and a policy switch on the way), then
times, as the client sees them (full HTTP round trip, JSON decoded):

1. first: one scrub to 90 % of the mission, with no cursor yet: a replay from zero;
   then `--settle` seconds for the background checkpoints (the server's memory before and
   after is printed: the cost of the parked engines);
2. random: 30 scrubs to uniformly random times in a fixed random order (each served by the
   parked cursor latest before it, a checkpoint or the previous scrub's);
3. play: `--steps` requests 10 simulated seconds apart from the start (what the timeline's
   play sends at 100x), each served by the cursor that served the one before;
4. back: 10 scrubs from the end towards the start, a tenth of the mission apart, while
   another mission runs live at 50x: its pace during the phase (simulated s per wall s)
   says whether replays hold up live missions (they should not: 50).

Prints p50/p95/max per phase and the answer's size.
"""

from __future__ import annotations

import argparse
import os
import random
import subprocess
import tempfile
import time
from pathlib import Path

import httpx
import psutil
from service_bench import AUTH, free_port, pct, start_server  # bench/, beside this script

from engine import reference_scenario


def wait_sim(api: httpx.Client, mid: int, done: object) -> dict[str, object]:
    while True:
        m: dict[str, object] = api.get(f"/api/missions/{mid}").json()
        if done(m):  # type: ignore[operator]
            return m
        time.sleep(0.05)


def timed(api: httpx.Client, mid: int, times: list[float]) -> tuple[list[float], list[int]]:
    took, sizes = [], []
    for t in times:
        t0 = time.perf_counter()
        r = api.get(f"/api/missions/{mid}/state", params={"t": t})
        r.raise_for_status()
        r.json()
        took.append((time.perf_counter() - t0) * 1000)
        sizes.append(len(r.content))
    return took, sizes


def report(name: str, took: list[float], sizes: list[int]) -> None:
    print(
        f"{name:7s} n={len(took):3d}  p50 {pct(took, 0.5):7.1f} ms  p95 {pct(took, 0.95):7.1f} ms"
        f"  max {max(took):7.1f} ms  answer {sum(sizes) / len(sizes) / 1024:6.1f} KB"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--scale", type=int, default=1)
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--settle", type=float, default=5.0)
    ap.add_argument("--per-mission", type=int, default=5, help="REGOLITH_PLAYBACK_PER_MISSION")
    args = ap.parse_args()
    port = free_port()
    os.environ["REGOLITH_PLAYBACK_PER_MISSION"] = str(args.per_mission)  # for start_server
    with tempfile.TemporaryDirectory() as tmp:
        proc = start_server(Path(tmp), port)
        try:
            with httpx.Client(
                base_url=f"http://127.0.0.1:{port}", headers=AUTH, timeout=600
            ) as api:
                scenario = reference_scenario().scaled(args.scale).model_dump(mode="json")
                body = {"seed": args.seed, "speed": 300, "scenario": scenario}
                mid = api.post("/api/missions", json=body).json()["id"]
                wait_sim(api, mid, lambda m: m["sim_time"] > 150)
                api.post(f"/api/missions/{mid}/robots/hauler-1/disable", json={"mode": "abrupt"})
                api.put(f"/api/missions/{mid}/policy", json={"policy": "coalition"})
                api.put(f"/api/missions/{mid}/speed", json={"speed": "max"})
                end = float(
                    wait_sim(api, mid, lambda m: m["status"] not in ("running", "paused"))[
                        "sim_time"
                    ]
                )  # type: ignore[arg-type]
                print(
                    f"scale {args.scale}, seed {args.seed}, {args.per_mission} cursor(s) per "
                    f"mission: the mission ends at t = {end:.0f} s"
                )
                server = psutil.Process(proc.pid)
                rss = server.memory_info().rss
                report("first", *timed(api, mid, [0.9 * end]))
                time.sleep(args.settle)
                grown = (server.memory_info().rss - rss) / 2**20
                print(f"server memory: {rss / 2**20:.0f} MB before, +{grown:.0f} MB with cursors")
                rng = random.Random(args.seed)
                report("random", *timed(api, mid, [rng.uniform(0, end) for _ in range(30)]))
                play = [min(end, 10.0 * i) for i in range(args.steps)]
                report("play", *timed(api, mid, play))
                live = api.post("/api/missions", json={"seed": 1, "speed": 50}).json()["id"]
                time.sleep(1.0)
                t0, s0 = time.perf_counter(), wait_sim(api, live, lambda m: True)["sim_time"]
                report("back", *timed(api, mid, [end * (10 - i) / 10 for i in range(10)]))
                s1 = wait_sim(api, live, lambda m: True)["sim_time"]
                pace = (float(s1) - float(s0)) / (time.perf_counter() - t0)  # type: ignore[arg-type]
                print(f"a live mission at 50x meanwhile: {pace:.1f} simulated s per wall s")
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()


if __name__ == "__main__":
    main()
