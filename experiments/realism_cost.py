"""The cost of each realism option on each policy (docs/experiments.md#the-cost-of-realism):
mean makespan per policy with the reference model (results/reference) and with each option
on alone and all four together (results/realism/<option>, sweeps of scenarios/realism/*.toml
and scenarios/lunar-realistic.toml), the ranking of the policies under each, and a figure.

    .venv/bin/python -m experiments.realism_cost [--seeds 0-99] [--figure docs/img/realism-cost.png]

Only the seeds every configuration ran are compared (paired by seed).
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = (
    ("reference", ROOT / "results" / "reference"),
    ("energy", ROOT / "results" / "realism" / "energy"),
    ("docks", ROOT / "results" / "realism" / "docks"),
    ("uncertainty", ROOT / "results" / "realism" / "uncertainty"),
    ("radio", ROOT / "results" / "realism" / "radio"),
    ("all four", ROOT / "results" / "realism" / "all"),
)


def load(path: Path) -> dict[tuple[str, int], float | None]:
    """(policy, seed) → makespan (None: the run did not complete)."""
    out: dict[tuple[str, int], float | None] = {}
    with (path / "runs.csv").open() as f:
        for row in csv.DictReader(f):
            done = row["completed"] == "true" and row["minerals_delivered"] == row["minerals_total"]
            out[(row["policy"], int(row["seed"]))] = float(row["makespan_s"]) if done else None
    return out


def table(seeds: set[int] | None = None) -> tuple[list[str], list[str], dict, dict]:
    data = {name: load(p) for name, p in CONFIGS if (p / "runs.csv").exists()}
    common = set.intersection(*({s for _, s in d} for d in data.values()))
    if seeds is not None:
        common &= seeds
    policies = sorted({p for d in data.values() for p, _ in d}, key=lambda p: p)
    means: dict[tuple[str, str], tuple[float, float, int, int]] = {}
    for name, d in data.items():
        for p in policies:
            vals = [d.get((p, s)) for s in sorted(common)]
            done = [v for v in vals if v is not None]
            mean = statistics.fmean(done) if done else math.nan
            sd = statistics.stdev(done) if len(done) > 1 else 0.0
            means[(name, p)] = (
                mean,
                1.96 * sd / math.sqrt(len(done)) if done else 0.0,
                len(done),
                len(vals),
            )
    ranks = {name: sorted(policies, key=lambda p: means[(name, p)][0]) for name in data}
    return list(data), policies, means, ranks


def markdown(configs: list[str], policies: list[str], means: dict, ranks: dict) -> str:
    head = "| policy | " + " | ".join(configs) + " |"
    rows = [head, "| --- |" + " ---: |" * len(configs)]
    for p in policies:
        cells = []
        for c in configs:
            m, ci, done, n = means[(c, p)]
            rank = ranks[c].index(p) + 1
            cost = "" if c == "reference" else f" ({m / means[('reference', p)][0] - 1:+.0%})"
            miss = "" if done == n else f", {n - done} incomplete"
            cells.append(f"{m:.0f} ± {ci:.0f}{cost} #{rank}{miss}")
        rows.append(f"| {p} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def figure(configs: list[str], policies: list[str], means: dict, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from engine import POLICIES

    fig, ax = plt.subplots(figsize=(10, 4.2))
    w = 0.8 / len(policies)
    for i, p in enumerate(policies):
        xs = [j + (i - len(policies) / 2 + 0.5) * w for j in range(len(configs))]
        ys = [means[(c, p)][0] for c in configs]
        es = [means[(c, p)][1] for c in configs]
        cls = POLICIES.get(p)
        ax.bar(
            xs,
            ys,
            w,
            yerr=es,
            label=cls.label if cls else p,
            color=cls.colour if cls else None,
            capsize=2,
        )
    ax.set_xticks(range(len(configs)), configs)
    ax.set_ylabel("mean makespan (s, 95 % CI)")
    ax.set_title("The cost of each realism option on each policy")
    ax.legend(ncol=4, fontsize=8, loc="upper left")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default=None, help="A-B: compare only these seeds")
    ap.add_argument("--figure", type=Path, default=None)
    a = ap.parse_args()
    seeds = None
    if a.seeds:
        lo, hi = (int(v) for v in a.seeds.split("-"))
        seeds = set(range(lo, hi + 1))
    configs, policies, means, ranks = table(seeds)
    print(markdown(configs, policies, means, ranks))
    for c in configs:
        print(f"ranking, {c}: " + " < ".join(ranks[c]))
    if a.figure:
        figure(configs, policies, means, a.figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
