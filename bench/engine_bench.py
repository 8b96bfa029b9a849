"""Engine speed: wall and CPU time per mission, simulated seconds per wall second, planner
queries and their median time, and peak memory — per policy, over seeds, at several scales.

    .venv/bin/python bench/engine_bench.py                 # scales 1 and 10
    .venv/bin/python bench/engine_bench.py --scales 1,10,100 --seeds 5

Each mission runs in a fresh child process so peak memory is its own and nothing is cached
across missions. Figures go to stdout as a table; docs/benchmarks.md records them.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import resource
import statistics
import sys
import time
from typing import Any


def _time_ompl_solves() -> list[float]:
    """Time every OMPL solve of the missions built after this call (in this process only).

    The engine never reads the wall clock, so the bench wraps the planner: `Mission` builds
    its `OmplPlanner` by the name `engine.mission.OmplPlanner`, which becomes a subclass that
    records each `_solve` (one query that a straight segment and the cache did not answer).
    """
    import engine.mission
    from engine.geometry import Point
    from engine.planning import OmplPlanner, Path

    seconds: list[float] = []

    class TimedOmplPlanner(OmplPlanner):
        def _solve(self, start: Point, goal: Point) -> Path:
            t0 = time.perf_counter()
            try:
                return super()._solve(start, goal)
            finally:
                seconds.append(time.perf_counter() - t0)

    engine.mission.OmplPlanner = TimedOmplPlanner  # type: ignore[misc]
    return seconds


def one_mission(args: tuple[str, int, int]) -> dict[str, Any]:
    policy, seed, scale = args
    from engine import Mission, reference_scenario

    solves = _time_ompl_solves()  # a fresh child process per mission: patched only here
    t0, c0 = time.perf_counter(), time.process_time()
    m = Mission(reference_scenario().scaled(scale), seed, policy)
    metrics = m.run()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    stats = m.ctx.planner.stats
    ompl = sorted(solves)
    return {
        "policy": policy,
        "seed": seed,
        "scale": scale,
        "completed": metrics["completed"],
        "makespan_s": metrics["makespan_s"] or m.now,
        "wall_s": wall,
        "cpu_s": cpu,
        "events": len(m.events),
        "messages": metrics["messages"],
        "queries": stats.queries,
        "ompl_queries": stats.ompl_queries,
        "ompl_median_ms": 1000 * ompl[len(ompl) // 2] if ompl else 0.0,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def run_isolated(args: tuple[str, int, int]) -> dict[str, Any]:
    ctx = mp.get_context("spawn")
    with ctx.Pool(1) as pool:
        return pool.apply(one_mission, (args,))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scales", default="1,10", help="comma-separated scale factors")
    ap.add_argument("--seeds", type=int, default=5, help="seeds per policy at scale 1")
    ap.add_argument("--policies", default="fcfs,coalition,nearest")
    ap.add_argument("--budget", type=float, default=600.0, help="stop starting scales after (s)")
    opts = ap.parse_args()
    start = time.perf_counter()
    print(
        f"{'scale':>5} {'policy':>9} {'n':>3} {'wall med':>9} {'wall min':>9} {'cpu med':>8} "
        f"{'sim s/wall s':>12} {'queries':>8} {'ompl':>6} {'ompl ms':>8} {'peak MB':>8} done"
    )
    for scale in (int(s) for s in opts.scales.split(",")):
        if time.perf_counter() - start > opts.budget:
            print(f"scale {scale}: skipped, the {opts.budget:.0f} s budget is spent")
            break
        seeds = opts.seeds if scale == 1 else 1
        for policy in opts.policies.split(","):
            rows = [run_isolated((policy, s, scale)) for s in range(seeds)]
            walls = [r["wall_s"] for r in rows]
            speed = statistics.median(r["makespan_s"] / r["wall_s"] for r in rows)
            print(
                f"{scale:>5} {policy:>9} {len(rows):>3} {statistics.median(walls):>8.3f}s "
                f"{min(walls):>8.3f}s {statistics.median(r['cpu_s'] for r in rows):>7.3f}s "
                f"{speed:>12.0f} "
                f"{statistics.median(r['queries'] for r in rows):>8.0f} "
                f"{statistics.median(r['ompl_queries'] for r in rows):>6.0f} "
                f"{statistics.median(r['ompl_median_ms'] for r in rows):>8.2f} "
                f"{max(r['peak_mb'] for r in rows):>8.0f} "
                f"{sum(r['completed'] for r in rows)}/{len(rows)}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
