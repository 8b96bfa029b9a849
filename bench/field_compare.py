"""Field runs against simulated runs of the same seeds: does running every robot as its own
process over Zenoh, on a wall clock × K, change how long the reference mission takes?

    .venv/bin/python bench/field_compare.py --seeds 10 --speed 100 --policy nearest

For each seed: the simulated makespan (`run_mission`, deterministic) and the makespan of one
field mission (`field.fleet_run.run_fleet`: world service, twelve agent processes on this
machine). Prints one line per seed and the summary docs/field.md records: the paired
difference field - simulated (mean, standard deviation, range) and its relative size.
"""

from __future__ import annotations

import argparse
import statistics
import sys


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--speed", type=float, default=100.0)
    ap.add_argument("--policy", default="nearest")
    args = ap.parse_args()

    from engine import reference_scenario, run_mission
    from field.fleet_run import run_fleet

    scen = reference_scenario()
    diffs: list[float] = []
    print(f"policy {args.policy}, field runs at {args.speed:g}x")
    print(
        f"{'seed':>4} {'simulated_s':>12} {'field_s':>10} {'diff_s':>8} {'rel':>7} "
        f"{'reann_sim':>9} {'reann_field':>11} {'wall_s':>7}"
    )
    for seed in range(args.seeds):
        sim = run_mission(scen, seed, args.policy)
        fld = run_fleet(scen, seed, args.policy, args.speed)
        if not fld["completed"] or sim["makespan_s"] is None:
            print(f"{seed:>4} simulated {sim['status']}, field {fld['status']}: no pair")
            continue
        d = fld["makespan_s"] - sim["makespan_s"]
        diffs.append(d / sim["makespan_s"])
        print(
            f"{seed:>4} {sim['makespan_s']:>12.1f} {fld['makespan_s']:>10.1f} {d:>+8.1f} "
            f"{d / sim['makespan_s']:>+7.1%} {sim['reannouncements']:>9} "
            f"{fld['reannouncements']:>11} {fld['wall_s']:>7.1f}",
            flush=True,
        )
    if len(diffs) >= 2:
        print(
            f"relative difference field - simulated over {len(diffs)} seeds: "
            f"mean {statistics.mean(diffs):+.1%}, sd {statistics.stdev(diffs):.1%}, "
            f"median {statistics.median(diffs):+.1%}, "
            f"range {min(diffs):+.1%} .. {max(diffs):+.1%}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
