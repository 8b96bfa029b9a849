"""Every registered policy on scenarios/lunar-realistic.toml (all four realism options on):
does every run complete with every mineral delivered? (docs/model.md: the options' acceptance.)

    nice .venv/bin/python bench/realism_check.py --seeds 0-19 [--workers 2]

Prints one line per policy: runs completed with every mineral delivered, mean makespan, robots
that ran dry, false failure verdicts, charges; exits 1 if any run fell short.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "lunar-realistic.toml"


def one(args: tuple[str, int]) -> dict[str, Any]:
    from engine import load_scenario, run_mission

    policy, seed = args
    m = run_mission(load_scenario(SCENARIO), seed, policy)
    m["ok"] = m["completed"] and m["minerals_delivered"] == m["minerals_total"]
    return m


def main() -> int:
    from engine import POLICIES

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-19", help="A-B, inclusive")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    lo, hi = (int(v) for v in a.seeds.split("-"))
    jobs = [(p, s) for p in POLICIES for s in range(lo, hi + 1)]
    with ProcessPoolExecutor(a.workers) as pool:
        runs = list(pool.map(one, jobs))
    bad = 0
    print(f"{'policy':<18} ok/runs  makespan_s  ran_dry  false_failures  charges")
    for p in POLICIES:
        mine = [r for r in runs if r["policy"] == p]
        ok = sum(r["ok"] for r in mine)
        bad += len(mine) - ok
        spans = [r["makespan_s"] for r in mine if r["ok"]]
        print(
            f"{p:<18} {ok:>2}/{len(mine):<4} {statistics.fmean(spans) if spans else 0:>10.0f}"
            f"  {sum(r['ran_dry'] for r in mine):>7}  {sum(r['false_failures'] for r in mine):>14}"
            f"  {statistics.fmean(r['charges'] for r in mine):>7.1f}"
        )
        for r in mine:
            if not r["ok"]:
                print(f"  seed {r['seed']}: {r['status']}, {r['minerals_delivered']} delivered")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
