"""What an unreliable bus costs: mean makespan (and its 95% CI) per policy at several loss
rates over many seeds, every mission checked complete.

    .venv/bin/python bench/faults_bench.py --losses 0,0.1,0.3,0.5 --seeds 20

Runs on all cores through a process pool. docs/faults.md records the table.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from scipy import stats


def one(args: tuple[str, int, float, float, float]) -> dict[str, Any]:
    from engine import parse_scenario, reference_scenario, run_mission

    policy, seed, loss, latency, jitter = args
    data = reference_scenario().model_dump()
    data["bus"] = {"loss": loss, "latency_s": latency, "jitter_s": jitter}
    m = run_mission(parse_scenario(data), seed, policy)
    return {"policy": policy, "loss": loss, "latency": latency, **m}


def ci95(xs: list[float]) -> float:
    if len(xs) < 2:
        return 0.0
    return float(stats.t.ppf(0.975, len(xs) - 1) * statistics.stdev(xs) / len(xs) ** 0.5)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--losses", default="0,0.1,0.3,0.5")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--latency", type=float, default=0.0)
    ap.add_argument("--jitter", type=float, default=0.0)
    ap.add_argument("--policies", default="fcfs,coalition,nearest")
    ap.add_argument("--workers", type=int, default=None)
    o = ap.parse_args()
    losses = [float(x) for x in o.losses.split(",")]
    policies = o.policies.split(",")
    jobs = [
        (p, s, loss, o.latency, o.jitter)
        for loss in losses
        for p in policies
        for s in range(o.seeds)
    ]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(o.workers) as pool:
        rows = list(pool.map(one, jobs, chunksize=4))
    print(
        f"{len(rows)} missions in {time.perf_counter() - t0:.0f} s "
        f"(latency {o.latency} s, jitter {o.jitter} s)"
    )
    print(
        "| policy | loss | completed | makespan mean ± 95% CI (s) | vs loss 0 | re-auctions "
        "| messages lost |"
    )
    print("|---|---|---|---|---|---|---|")
    for p in policies:
        base = None
        for loss in losses:
            sel = [r for r in rows if r["policy"] == p and r["loss"] == loss]
            ms = [r["makespan_s"] for r in sel if r["completed"]]
            mean = statistics.fmean(ms) if ms else float("nan")
            base = mean if base is None else base
            print(
                f"| {p} | {loss:g} | {sum(r['completed'] for r in sel)}/{len(sel)} "
                f"| {mean:.0f} ± {ci95(ms):.0f} | {100 * (mean / base - 1):+.1f}% "
                f"| {statistics.fmean(r['reauctions'] for r in sel):.1f} "
                f"| {statistics.fmean(r['messages_lost'] for r in sel):.0f} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
