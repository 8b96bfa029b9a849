"""The exact planner on the queries a mission really asks: CPU time per solve.

    .venv/bin/python bench/mission_queries_bench.py --scale 100 --until 150

Runs the reference mission scaled K× (seed 0, FCFS, exact planner) to simulated time
`--until`, keeping every query the planner had to solve (those a straight segment and the path
cache did not answer), then times the same queries, in order, on a fresh planner of the same
world: the world's graph starts cold as in the mission and warms up the same way. Unlike
bench/planner_bench.py's random cross-map queries, these are local (a robot to a site) and
asked by hundreds of robots at once. Prints solves, CPU ms per solve (median, mean, p95) and
a checksum of the path lengths (equal across planner versions that find the same paths).

By default the queries are answered as the planner answers them, from the goals' distance
fields (engine/tangent_field.py; the first solve opens the whole graph, timed apart as well
as in the total); `--a-star` times one A* query each instead (engine/tangent_query.py, what
the planner did before the fields).
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import time

import numpy as np

import engine.mission
from engine import Mission, reference_scenario
from engine.geometry import Point, path_length
from engine.planning import Path, PlanningError
from engine.tangent_planner import TangentPlanner


def mission_queries(scale: int, until: float) -> tuple[Mission, list[tuple[Point, Point]]]:
    queries: list[tuple[Point, Point]] = []

    class Recording(TangentPlanner):
        def _solve(self, start: Point, goal: Point) -> Path:
            queries.append((start, goal))
            return super()._solve(start, goal)

    engine.mission.TangentPlanner = Recording  # type: ignore[misc]
    try:
        m = Mission(reference_scenario().scaled(scale), 0, "fcfs", "exact")
        m.advance(until)
    finally:
        engine.mission.TangentPlanner = TangentPlanner  # type: ignore[misc]
    return m, queries


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=int, default=100)
    ap.add_argument("--until", type=float, default=150.0, help="simulated seconds")
    ap.add_argument("--a-star", action="store_true", help="one A* query per solve (as before)")
    args = ap.parse_args()
    m, queries = mission_queries(args.scale, args.until)
    planner = TangentPlanner(m.world)
    solve = planner.graph.shortest if args.a_star else planner._solve
    opening = 0.0
    if not args.a_star:
        t0 = time.process_time()
        planner.flat  # noqa: B018 - the whole graph, opened (timed apart; the first solve's)
        opening = time.process_time() - t0
    ms: list[float] = []
    total = 0.0
    for a, b in queries:
        t0 = time.process_time()
        with contextlib.suppress(PlanningError):  # counted in the time, not in the sum
            total += path_length(solve(a, b))
        ms.append((time.process_time() - t0) * 1e3)
    ms[0] += opening * 1e3
    print(
        f"scale {args.scale}, to t = {args.until:.0f} s: {len(queries)} solves on "
        f"{len(m.world.craters)} craters, {planner.graph.opened} rims opened; "
        + ("one A* query each" if args.a_star else f"goal fields ({opening:.2f} s opening all)")
    )
    print(
        f"CPU ms per solve: median {statistics.median(ms):.3f}, mean {statistics.fmean(ms):.3f}, "
        f"p95 {np.percentile(ms, 95):.3f}; total {sum(ms) / 1e3:.2f} s"
    )
    print(f"sum of path lengths {total:.6f} m")


if __name__ == "__main__":
    main()
