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
from dataclasses import dataclass, replace
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


TARGETS = {1: 0.10, 10: 3.0, 100: 120.0}
"""The scale targets for wall time per scale (seconds, median mission)."""
SLOPE_TARGET = 1.3
CHUNK_S = 250.0
"""Simulated seconds advanced between looks at the mission's wall-time budget."""


@dataclass(frozen=True)
class Run:
    """One mission to measure (sent to a fresh process, so plain picklable fields)."""

    policy: str
    seed: int
    scale: int
    planner: str
    budget: float  # wall seconds, then it stops (its row says how far it got)
    busy_bid: str
    stop: float = math.inf  # simulated seconds, then it stops
    profile: int = 0  # > 0: under cProfile, returning that many top functions (cumulative)


def one_mission(run: Run) -> dict[str, Any]:
    """One mission, advanced until it ends, its wall time passes `run.budget` seconds or its
    simulated time reaches `run.stop`."""
    policy, seed, scale, planner = run.policy, run.seed, run.scale, run.planner
    budget, profile, busy_bid, stop = run.budget, run.profile, run.busy_bid, run.stop
    import cProfile
    import io
    import pstats

    from engine import Mission, reference_scenario
    from engine.collector import collector_paused
    from engine.scenario import Protocol

    solves = _time_solves()  # a fresh child process per mission: patched only here
    if planner == "ompl":
        # the engine imports OMPL when it builds its first planner: an import (~0.06-0.1 s,
        # half the reference mission), not the mission's work, so it is done before the clock
        import importlib

        for mod in ("ompl.base", "ompl.geometric", "ompl.util"):
            importlib.import_module(mod)
    prof = cProfile.Profile() if profile else None
    t0, c0 = time.perf_counter(), time.process_time()
    if prof is not None:
        prof.enable()
    scenario = reference_scenario().scaled(scale)
    protocol = Protocol.model_validate({**scenario.protocol.model_dump(), "busy_bid": busy_bid})
    scenario = scenario.model_copy(update={"protocol": protocol})
    # headless, as `run_mission` and `regolith run`: events streamed, not kept
    m = Mission(scenario, seed, policy, planner, keep_events=False)  # type: ignore[arg-type]
    until = 0.0
    with collector_paused():  # as `run_mission` and `regolith run` (engine/collector.py)
        while not m.done and time.perf_counter() - t0 < budget and until < stop:
            until = min(until + CHUNK_S, stop)
            m.advance(until)
    if prof is not None:
        prof.disable()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    metrics = m.metrics()
    top = ""
    if prof is not None:
        out = io.StringIO()
        pstats.Stats(prof, stream=out).sort_stats("cumulative").print_stats(profile)
        top = out.getvalue()
    stats = m.ctx.planner.stats
    timed = sorted(solves)
    return {
        "policy": policy,
        "seed": seed,
        "scale": scale,
        "completed": metrics["completed"],
        "finished": m.done,
        "sim_s": m.now,
        "robots": sum(1 for r in m.ctx.robots.values() if r.rtype != "operator"),
        "delivered": m.ctx.terrain.delivered,
        "minerals": m.ctx.terrain.minerals_total,
        "makespan_s": metrics["makespan_s"] or m.now,
        "wall_s": wall,
        "cpu_s": cpu,
        "events": m.ctx.observer.log.emitted,
        "messages": metrics["messages"],
        "queries": stats.queries,
        "solves": len(timed),
        "solve_median_ms": 1000 * timed[len(timed) // 2] if timed else 0.0,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "profile": top,
    }


def run_isolated(run: Run) -> dict[str, Any]:
    ctx = mp.get_context("spawn")
    with ctx.Pool(1) as pool:
        return pool.apply(one_mission, (run,))


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
    ap.add_argument(
        "--busy-bid",
        default="once",
        choices=("once", "silent"),
        help="protocol.busy_bid: the specification's -inf from every busy robot, or silence",
    )
    ap.add_argument("--budget", type=float, default=900.0, help="stop starting scales after (s)")
    ap.add_argument(
        "--mission-budget",
        type=float,
        default=1800.0,
        help="stop a mission after this many wall seconds (its row says how far it got)",
    )
    ap.add_argument(
        "--until",
        type=float,
        default=math.inf,
        help="stop a mission at this simulated time (its row says the wall and CPU to there)",
    )
    ap.add_argument(
        "--profile",
        type=int,
        default=0,
        metavar="N",
        help="for each scale that misses its target, profile one more mission (first policy, "
        "within the mission budget) and print its N top functions by cumulative time",
    )
    opts = ap.parse_args()
    start = time.perf_counter()
    print(
        f"{'scale':>5} {'robots':>6} {'policy':>9} {'planner':>7} {'n':>3} {'wall med':>9} "
        f"{'wall min':>9} {'cpu med':>8} {'sim s/wall s':>12} {'queries':>8} {'solves':>6} "
        f"{'solve ms':>8} {'peak MB':>8} {'delivered':>11} done"
    )
    walls: dict[str, list[tuple[int, float]]] = {}
    measured: dict[int, dict[str, Any]] = {}  # per scale, the first policy's figures
    for scale in (int(s) for s in opts.scales.split(",")):
        if time.perf_counter() - start > opts.budget:
            print(f"scale {scale}: skipped, the {opts.budget:.0f} s budget is spent")
            break
        seeds = opts.seeds if scale == 1 else 1
        planner = "exact" if opts.exact_from and scale >= opts.exact_from else opts.planner
        for policy in opts.policies.split(","):
            runs = [
                Run(policy, s, scale, planner, opts.mission_budget, opts.busy_bid, opts.until)
                for s in range(seeds)
            ]
            rows = [run_isolated(r) for r in runs]
            wall = statistics.median(r["wall_s"] for r in rows)
            finished = all(r["finished"] for r in rows)
            if finished:
                walls.setdefault(policy, []).append((rows[0]["robots"], wall))
            measured.setdefault(scale, {"run": runs[0], "rows": rows})
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
            if not finished:
                r = max(rows, key=lambda r: r["wall_s"])
                print(
                    f"      not finished: stopped after {r['wall_s']:.0f} s wall at simulated "
                    f"t = {r['sim_s']:.0f} s, {r['delivered']}/{r['minerals']} delivered"
                )
    slopes: dict[str, float] = {}
    for policy, points in walls.items():
        k = slope(points)
        if k is not None:
            slopes[policy] = k
            teams = ", ".join(str(n) for n, _ in points)
            print(f"log-log slope of wall time over team size ({teams}), {policy}: {k:.2f}")
    missed = print_targets(measured, slopes)
    if opts.profile:
        for scale in missed:
            run = measured[scale]["run"]
            print(f"\nprofile, scale {scale}, {run.policy}, {run.planner} (one more mission):")
            print(run_isolated(replace(run, profile=opts.profile))["profile"])
    return 0


def print_targets(measured: dict[int, dict[str, Any]], slopes: dict[str, float]) -> list[int]:
    """The scale targets against what was measured; returns the scales that missed theirs."""
    print("\ntarget                         measured        target    verdict")
    missed = []
    for scale, target in TARGETS.items():
        if scale not in measured:
            continue
        rows = measured[scale]["rows"]
        wall = statistics.median(r["wall_s"] for r in rows)
        all_in = all(r["finished"] and r["delivered"] == r["minerals"] for r in rows)
        if all(r["finished"] for r in rows):
            shown = f"{wall:.3f} s"
            verdict = "met" if wall <= target and all_in else f"{wall / target:.1f}x over"
        else:
            sim = min(r["sim_s"] for r in rows)
            shown = f"> {wall:.0f} s"
            verdict = f"not finished (t = {sim:.0f} s simulated)"
        if not all_in:
            verdict += ", minerals missing"
        if scale == 100:
            verdict += f", peak {max(r['peak_mb'] for r in rows):.0f} MB"
        if not verdict.startswith("met"):
            missed.append(scale)
        name = f"scale {scale}, {measured[scale]['run'].policy}, median wall"
        print(f"{name:<30} {shown:<15} <= {target:<6g} {verdict}")
    for policy, k in slopes.items():
        verdict = "met" if k <= SLOPE_TARGET else f"{k - SLOPE_TARGET:.2f} over"
        print(f"{'log-log slope, ' + policy:<30} {k:<15.2f} <= {SLOPE_TARGET:<6g} {verdict}")
    return missed


if __name__ == "__main__":
    sys.exit(main())
