"""Engine speed: wall and CPU time per mission, simulated seconds per wall second, planner
queries and their median time, peak memory and whether every mineral was delivered — per
policy, over seeds, at several scales — and how wall time grows with the team (log-log slope).

    .venv/bin/python bench/engine_bench.py                 # scales 1 and 10
    .venv/bin/python bench/engine_bench.py --scales 1,10,100 --seeds 5

Each mission runs in a fresh child process so peak memory is its own and nothing is cached
across missions. Scales from `--exact-from` on (100 by default) plan with the exact
tangent-graph planner instead of RRT-Connect (the `planner` column says which). Figures go
to stdout as a table; docs/benchmarks.md records them.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import resource
import statistics
import sys
import time
from typing import Any


def _time_solves() -> list[float]:
    """Time every planner solve of the missions built after this call (in this process only).

    The engine never reads the wall clock, so the bench wraps the planners: `Mission` builds
    them by the names `engine.mission.OmplPlanner` and `engine.mission.TangentPlanner`, which
    become subclasses that record each `_solve` (one query that a straight segment and the
    cache did not answer).
    """
    import engine.mission
    from engine.geometry import Point
    from engine.planning import OmplPlanner, Path
    from engine.tangent_planner import TangentPlanner

    seconds: list[float] = []

    def timed(base: type[Any]) -> type[Any]:
        """`base` with each solve's wall time appended to `seconds`."""

        class Timed(base):  # type: ignore[misc,valid-type]
            def _solve(self, start: Point, goal: Point) -> Path:
                t0 = time.perf_counter()
                try:
                    return super()._solve(start, goal)  # type: ignore[no-any-return]
                finally:
                    seconds.append(time.perf_counter() - t0)

        return Timed

    TimedOmplPlanner, TimedTangentPlanner = timed(OmplPlanner), timed(TangentPlanner)

    engine.mission.OmplPlanner = TimedOmplPlanner  # type: ignore[misc]
    engine.mission.TangentPlanner = TimedTangentPlanner  # type: ignore[misc]
    return seconds


def one_mission(args: tuple[str, int, int, str]) -> dict[str, Any]:
    policy, seed, scale, planner = args
    from engine import Mission, reference_scenario

    solves = _time_solves()  # a fresh child process per mission: patched only here
    if planner == "ompl":
        # the engine imports OMPL when it builds its first planner: an import (~0.06-0.1 s,
        # half the reference mission), not the mission's work, so it is done before the clock
        import importlib

        for mod in ("ompl.base", "ompl.geometric", "ompl.util"):
            importlib.import_module(mod)
    t0, c0 = time.perf_counter(), time.process_time()
    m = Mission(reference_scenario().scaled(scale), seed, policy, planner)  # type: ignore[arg-type]
    metrics = m.run()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    stats = m.ctx.planner.stats
    timed = sorted(solves)
    return {
        "policy": policy,
        "seed": seed,
        "scale": scale,
        "completed": metrics["completed"],
        "robots": sum(1 for r in m.ctx.robots.values() if r.rtype != "operator"),
        "delivered": m.ctx.field.delivered,
        "minerals": m.ctx.field.minerals_total,
        "makespan_s": metrics["makespan_s"] or m.now,
        "wall_s": wall,
        "cpu_s": cpu,
        "events": len(m.events),
        "messages": metrics["messages"],
        "queries": stats.queries,
        "solves": len(timed),
        "solve_median_ms": 1000 * timed[len(timed) // 2] if timed else 0.0,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def run_isolated(args: tuple[str, int, int, str]) -> dict[str, Any]:
    ctx = mp.get_context("spawn")
    with ctx.Pool(1) as pool:
        return pool.apply(one_mission, (args,))


def slope(points: list[tuple[int, float]]) -> float | None:
    """Least-squares slope of log(wall) over log(team size): 1 is linear growth."""
    if len(points) < 2:
        return None
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(w) for _, w in points]
    mx, my = statistics.fmean(xs), statistics.fmean(ys)
    den = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / den if den else None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scales", default="1,10", help="comma-separated scale factors")
    ap.add_argument("--seeds", type=int, default=5, help="seeds per policy at scale 1")
    ap.add_argument("--policies", default="fcfs,coalition,nearest")
    ap.add_argument("--planner", default="ompl", choices=("ompl", "exact"))
    ap.add_argument(
        "--exact-from", type=int, default=100, help="scales >= this use the exact planner (0: none)"
    )
    ap.add_argument("--budget", type=float, default=900.0, help="stop starting scales after (s)")
    opts = ap.parse_args()
    start = time.perf_counter()
    print(
        f"{'scale':>5} {'robots':>6} {'policy':>9} {'planner':>7} {'n':>3} {'wall med':>9} "
        f"{'wall min':>9} {'cpu med':>8} {'sim s/wall s':>12} {'queries':>8} {'solves':>6} "
        f"{'solve ms':>8} {'peak MB':>8} {'delivered':>11} done"
    )
    walls: dict[str, list[tuple[int, float]]] = {}
    for scale in (int(s) for s in opts.scales.split(",")):
        if time.perf_counter() - start > opts.budget:
            print(f"scale {scale}: skipped, the {opts.budget:.0f} s budget is spent")
            break
        seeds = opts.seeds if scale == 1 else 1
        planner = "exact" if opts.exact_from and scale >= opts.exact_from else opts.planner
        for policy in opts.policies.split(","):
            rows = [run_isolated((policy, s, scale, planner)) for s in range(seeds)]
            wall = statistics.median(r["wall_s"] for r in rows)
            walls.setdefault(policy, []).append((rows[0]["robots"], wall))
            speed = statistics.median(r["makespan_s"] / r["wall_s"] for r in rows)
            delivered = f"{min(r['delivered'] for r in rows)}/{rows[0]['minerals']}"
            print(
                f"{scale:>5} {rows[0]['robots']:>6} {policy:>9} {planner:>7} {len(rows):>3} "
                f"{wall:>8.3f}s {min(r['wall_s'] for r in rows):>8.3f}s "
                f"{statistics.median(r['cpu_s'] for r in rows):>7.3f}s "
                f"{speed:>12.0f} "
                f"{statistics.median(r['queries'] for r in rows):>8.0f} "
                f"{statistics.median(r['solves'] for r in rows):>6.0f} "
                f"{statistics.median(r['solve_median_ms'] for r in rows):>8.2f} "
                f"{max(r['peak_mb'] for r in rows):>8.0f} "
                f"{delivered:>11} "
                f"{sum(r['completed'] for r in rows)}/{len(rows)}",
                flush=True,
            )
    for policy, points in walls.items():
        k = slope(points)
        if k is not None:
            teams = ", ".join(str(n) for n, _ in points)
            print(f"log-log slope of wall time over team size ({teams}), {policy}: {k:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
