"""Path planners compared on the same queries: time per query and path length over the
true shortest path, for queries whose straight segment a crater blocks.

    .venv/bin/python bench/planner_bench.py                       # seeds 0-4, 200 queries each
    .venv/bin/python bench/planner_bench.py --seeds 0-1 --queries 100 --scale 10 --check 2
    .venv/bin/python bench/planner_bench.py --seeds 0-1 --queries 50 --scale 100 --check 0

Per seed the reference scenario's world is generated and `--queries` random free start and
goal points with a blocked straight segment are drawn (the seed's own stream, so the same
command gives the same queries). Each query is answered by:

- `exact`: shortest paths over the craters' tangent graph (engine/tangent_planner.py);
- `ompl`: RRT-Connect with simplification (engine/planning.py), seeded per query;
- a dense visibility graph over points just outside every rim (`--check` queries per seed,
  slow): an independent upper bound on the shortest length, so `exact / dense ≤ 1` shows
  the tangent graph is exact.

The true shortest length is taken as the exact planner's (its excess over the true arcs is
the circumscribed polygon's, ≤ 0.05 %). Times are CPU times of this process (the machine is
shared; wall times varied 5× with the load), and the exact planner's include opening the rims
its route reaches (its graph is built lazily and kept for the world's later queries).
Figures go to stdout; docs/benchmarks.md records them.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from engine.geometry import Point, path_length
from engine.planning import OmplPlanner
from engine.scenario import reference_scenario
from engine.tangent_planner import TangentPlanner
from engine.visibility_check import dense_visibility_length
from engine.world import World, generate_world


def seeds_of(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def blocked_queries(w: World, rng: np.random.Generator, n: int) -> list[tuple[Point, Point]]:
    out: list[tuple[Point, Point]] = []
    while len(out) < n:
        a = (float(rng.uniform(0, w.width)), float(rng.uniform(0, w.height)))
        b = (float(rng.uniform(0, w.width)), float(rng.uniform(0, w.height)))
        if w.is_free(*a) and w.is_free(*b) and not w.index.segment_free(a, b):
            out.append((a, b))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-4")
    ap.add_argument("--queries", type=int, default=200)
    ap.add_argument("--scale", type=int, default=1)
    ap.add_argument(
        "--check", type=int, default=10, help="queries per seed checked densely (slow; 0 at scale)"
    )
    args = ap.parse_args()
    scen = reference_scenario().scaled(args.scale) if args.scale > 1 else reference_scenario()
    rows: dict[str, list[float]] = {"exact_ms": [], "ompl_ms": [], "ratio": [], "dense": []}
    builds: list[float] = []
    for seed in seeds_of(args.seeds):
        rng = np.random.default_rng(seed)
        w = generate_world(scen, rng)
        exact, ompl = TangentPlanner(w), OmplPlanner(w, np.random.default_rng(seed))
        t0 = time.process_time()
        exact.graph  # noqa: B018 - built outside the timed queries (reported on its own)
        builds.append(time.process_time() - t0)
        for i, (a, b) in enumerate(blocked_queries(w, rng, args.queries)):
            t0 = time.process_time()
            pe = exact.graph.shortest(a, b)
            t1 = time.process_time()
            po = ompl._solve(a, b)
            t2 = time.process_time()
            rows["exact_ms"].append((t1 - t0) * 1e3)
            rows["ompl_ms"].append((t2 - t1) * 1e3)
            rows["ratio"].append(path_length(po) / path_length(pe))
            if i < args.check:
                rows["dense"].append(path_length(pe) / dense_visibility_length(w, a, b, per_rim=90))
        ompl.close()
        print(
            f"seed {seed}: {len(w.craters)} craters, graph set up in {builds[-1] * 1e3:.1f} ms, "
            f"{exact.graph.opened} rims opened by the queries"
        )
    n = len(rows["ratio"])
    r = np.asarray(rows["ratio"])
    print(f"\n{n} blocked queries, scale {args.scale}, seeds {args.seeds}")
    print("| planner | median ms/query | p95 ms/query | length / shortest: mean | p95 | max |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name, key, ratio in (("exact", "exact_ms", np.ones(n)), ("ompl", "ompl_ms", r)):
        ms = np.asarray(rows[key])
        print(
            f"| {name} | {statistics.median(ms):.2f} | {np.percentile(ms, 95):.2f} | "
            f"{ratio.mean():.4f} | {np.percentile(ratio, 95):.4f} | {ratio.max():.4f} |"
        )
    print(f"\ngraph set-up median {statistics.median(builds) * 1e3:.1f} ms")
    if rows["dense"]:
        print(
            f"exact / dense visibility graph ({len(rows['dense'])} queries): max "
            f"{max(rows['dense']):.6f} (≤ 1.0001: only the arcs, driven as polygons, can be longer)"
        )


if __name__ == "__main__":
    main()
