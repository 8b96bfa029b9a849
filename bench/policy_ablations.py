"""Policy 4's rules switched off one at a time, and the central baseline without its lead.

    .venv/bin/python bench/policy_ablations.py              # seeds 0-99, all variants
    .venv/bin/python bench/policy_ablations.py --seeds 30 --variants lookahead,no-lead

Each variant is a subclass of `Lookahead` or `Central` with one class attribute changed,
registered under its own name (not a number) in every worker process. Prints, per variant,
the mean makespan with its 95% CI, the paired difference from Policy 2 on the same seeds
with the paired t-test's p-value, and total distance relative to Policy 2. docs/policies.md
records the figures.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import statistics
import sys
from typing import Any

VARIANTS: dict[str, tuple[str, dict[str, Any]]] = {
    "coalition": ("", {}),  # Policy 2, the reference every variant is compared with
    "lookahead": ("", {}),
    "no-lead": ("lookahead", {"lead": False}),
    "no-time-bids-no-queue": ("lookahead", {"time_bids": False, "queue": {}}),
    "first-auction-only": ("lookahead", {"bid_all": False}),
    "central-greedy": ("", {}),
    "central-greedy-no-lead": ("central-greedy", {"lead": False}),
}


def register_variants() -> None:
    from engine.policies import POLICIES

    for name, (base, attrs) in VARIANTS.items():
        if base and name not in POLICIES:
            # registered by name only: the numbered registry (and the API's enum) stay as they are
            POLICIES[name] = type(name, (POLICIES[base],), {"name": name, **attrs})


def one_run(args: tuple[str, int]) -> tuple[str, int, float, float]:
    from engine import reference_scenario, run_mission

    register_variants()
    name, seed = args
    m = run_mission(reference_scenario(), seed, name)
    if not m["completed"]:
        raise RuntimeError(f"{name} seed {seed}: {m['status']}")
    return name, seed, float(m["makespan_s"]), float(m["distance_total"])


def main() -> None:
    from scipy import stats  # type: ignore[import-untyped]

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=100, help="seeds 0..N-1")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--workers", type=int, default=None)
    args = ap.parse_args()
    names = [v.strip() for v in args.variants.split(",")]
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        sys.exit(f"unknown variants: {unknown} (known: {', '.join(VARIANTS)})")
    if "coalition" not in names:
        names.insert(0, "coalition")
    jobs = [(n, s) for n in names for s in range(args.seeds)]
    with mp.Pool(args.workers) as pool:
        rows = pool.map(one_run, jobs, chunksize=4)
    by: dict[str, dict[int, tuple[float, float]]] = {}
    for name, seed, makespan, distance in rows:
        by.setdefault(name, {})[seed] = (makespan, distance)
    seeds = range(args.seeds)
    ref_m = [by["coalition"][s][0] for s in seeds]
    ref_d = statistics.fmean(by["coalition"][s][1] for s in seeds)
    print(f"{len(seeds)} seeds; difference and distance relative to Policy 2 (coalition)\n")
    print(
        f"{'variant':<24} {'makespan (s)':>17} {'paired diff':>12} {'p (paired t)':>12} {'dist':>6}"
    )
    for name in names:
        ms = [by[name][s][0] for s in seeds]
        mean = statistics.fmean(ms)
        half = stats.t.ppf(0.975, len(ms) - 1) * statistics.stdev(ms) / len(ms) ** 0.5
        diff = statistics.fmean(a - b for a, b in zip(ms, ref_m, strict=True))
        p = stats.ttest_rel(ms, ref_m).pvalue if name != "coalition" else float("nan")
        dist = statistics.fmean(by[name][s][1] for s in seeds) / ref_d
        print(f"{name:<24} {mean:>9.1f} ± {half:>5.1f} {diff:>+12.1f} {p:>12.2g} {dist:>6.3f}")


if __name__ == "__main__":
    main()
