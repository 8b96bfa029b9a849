"""Liveness under random operator actions: how many missions a restored team fails to finish
(the target is none), and how long finishing takes once every robot is back.

    .venv/bin/python bench/chaos_bench.py --seeds 200 --actions 14 --window 2500
    .venv/bin/python bench/chaos_bench.py --seeds 100 --planner straight --loss 0.2 --latency 0.1

Every registered policy runs every seed: a fault-free mission, then the same seed under
`--actions` random operator actions (disable graceful/abrupt, enable, add, inject, switch
policy; two at one instant now and then) over the first `--window` simulated seconds, then
every robot enabled (experiments/chaos.py). Runs on all cores through a process pool, with
the real OMPL planner unless `--planner exact` or `--planner straight`. `--loss` and
`--latency` put both missions on an unreliable bus (per-receiver loss; latency and jitter
both `--latency` seconds): the faults of the bus and the operator's at once; `--scenario`
runs another scenario (the realism options' `scenarios/lunar-realistic.toml`, say).
docs/faults.md records the figures.
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from engine import Scenario


def one(args: tuple[int, str, int, float, str, Scenario]) -> dict[str, Any]:
    from engine import run_mission
    from experiments.chaos import chaos_mission

    seed, policy, actions, window, planner, scenario = args
    base = run_mission(scenario, seed, policy, planner=planner)  # type: ignore[arg-type]
    run = chaos_mission(scenario, seed, policy, actions=actions, window_s=window, planner=planner)
    after = None if run.makespan_s is None else run.makespan_s - run.restored_at
    return {
        "seed": seed,
        "policy": policy,
        "finished": run.finished,
        "status": run.status,
        "delivered": run.delivered,
        "baseline_s": base["makespan_s"],
        "after_restore_s": after,
        "actions": len(run.actions),
    }


def scenario_of(o: argparse.Namespace) -> Scenario:
    """The scenario file's (the reference without one), on the bus the options ask for."""
    from engine import load_scenario, parse_scenario, reference_scenario

    scenario = reference_scenario() if o.scenario is None else load_scenario(o.scenario)
    if o.loss or o.latency:
        bus = {"loss": o.loss, "latency_s": o.latency, "jitter_s": o.latency}
        scenario = parse_scenario({**scenario.model_dump(), "bus": bus})
    return scenario


def main() -> int:
    from engine import ScenarioError
    from engine.policies import POLICIES

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--actions", type=int, default=14)
    ap.add_argument("--window", type=float, default=2500.0)
    ap.add_argument("--planner", choices=["ompl", "exact", "straight"], default="ompl")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--scenario", help="a .toml or .json scenario (default: the reference)")
    ap.add_argument("--loss", type=float, default=0.0, help="per-receiver loss probability")
    ap.add_argument("--latency", type=float, default=0.0, help="bus latency and jitter (s)")
    o = ap.parse_args()
    try:
        scenario = scenario_of(o)
    except ScenarioError as exc:
        ap.error(str(exc))
    jobs = [
        (s, p, o.actions, o.window, o.planner, scenario)
        for s in range(o.first_seed, o.first_seed + o.seeds)
        for p in sorted(POLICIES)
    ]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(o.workers) as pool:
        rows = list(pool.map(one, jobs, chunksize=4))
    wall = time.perf_counter() - t0
    stuck = [r for r in rows if not r["finished"]]
    print(
        f"{len(rows)} missions ({o.seeds} seeds x {len(POLICIES)} policies), "
        f"{o.actions} actions over {o.window:g} s, planner {o.planner}, "
        f"scenario {scenario.name}, bus loss {o.loss:g}, latency {o.latency:g} s: {wall:.0f} s wall"
    )
    print(f"stuck (not completed with every mineral delivered): {len(stuck)}")
    for r in stuck:
        print(f"  seed {r['seed']} {r['policy']}: {r['status']}, {r['delivered']} delivered")
    print(f"{'policy':<10} {'n':>4} {'after/base p50':>15} {'p95':>6} {'max':>6}")
    for p in sorted(POLICIES):
        ratios = [
            r["after_restore_s"] / r["baseline_s"]
            for r in rows
            if r["policy"] == p and r["finished"] and r["baseline_s"]
        ]
        if ratios:
            q = np.percentile(ratios, [50, 95, 100])
            print(f"{p:<10} {len(ratios):>4} {q[0]:>15.2f} {q[1]:>6.2f} {q[2]:>6.2f}")
    return 1 if stuck else 0


if __name__ == "__main__":
    sys.exit(main())
