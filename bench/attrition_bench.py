"""Attrition: how many missions the survivors fail to finish when all but one robot of each
type fail for good (the target is none).

    .venv/bin/python bench/attrition_bench.py --seeds 100

Every registered policy runs every seed on the reference scenario with three robots of each
type (experiments/attrition.py): each type's robots but one fail, abruptly or gracefully,
within 40 s of one another at a random time in the first 1,500 s, and none comes back. Runs
on all cores through a process pool, with the straight-line planner unless `--planner`.
Prints the stalled runs with their failures and the count per policy; exit 1 if any stalled.
docs/faults.md records the figures.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor

from experiments.attrition import AttritionRun


def one(args: tuple[int, str, str, int]) -> AttritionRun:
    from engine import reference_scenario
    from experiments.attrition import attrition_mission, attrition_team

    seed, policy, planner, each = args
    team = attrition_team(reference_scenario(), each)
    return attrition_mission(team, seed, policy, planner=planner)


def main(argv: list[str] | None = None) -> int:
    from engine.policies import POLICIES

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=50, help="seeds 0..N-1 for every policy")
    p.add_argument("--first", type=int, default=0, help="the first seed")
    p.add_argument("--policies", default=",".join(sorted(POLICIES)))
    p.add_argument("--planner", choices=["straight", "ompl", "exact"], default="straight")
    p.add_argument("--each", type=int, default=3, help="robots of each type (all but one fail)")
    o = p.parse_args(argv)
    policies = [s.strip() for s in o.policies.split(",") if s.strip()]
    unknown = [x for x in policies if x not in POLICIES]
    if unknown:
        p.error(f"unknown policies {unknown}")  # argparse: the message and exit code 2
    if o.seeds < 1:
        p.error("--seeds must be at least 1")
    if not 2 <= o.each <= 20:
        p.error("--each must be between 2 and 20")
    seeds = range(o.first, o.first + o.seeds)
    jobs = [(s, pol, o.planner, o.each) for pol in policies for s in seeds]
    start = time.perf_counter()
    stalled: Counter[str] = Counter()
    with ProcessPoolExecutor() as pool:
        for run in pool.map(one, jobs):
            if not run.finished:
                stalled[run.policy] += 1
                fails = [(round(t), n, m) for t, n, m in run.failures]
                got = f"{run.status} {run.delivered}/{run.total}"
                print(f"seed {run.seed} {run.policy}: {got} {fails}")
    wall = time.perf_counter() - start
    for pol in policies:
        print(f"{pol:18} {stalled[pol]:3d} of {o.seeds} stalled")
    total = sum(stalled.values())
    print(f"{total} of {len(jobs)} missions stalled ({wall:.0f} s wall)")
    return 1 if total else 0


if __name__ == "__main__":
    sys.exit(main())
