"""The cost of each realism option on each policy (docs/experiments.md#the-cost-of-realism).

Six configurations over the same seeds: the reference model (the `reference` sweep) and the
`realism/<option>` sweeps of `experiments.reproduce` (each option alone at the values of
scenarios/lunar-realistic.toml, then all four together). Runs are paired by seed: a policy's
cost of an option is its per-seed makespan difference against the reference model, and a
change in the ranking counts only where a pair of policies is ordered significantly one way
under the reference and significantly the other way under the option (paired t-test on
per-seed differences, Holm-corrected over the pairs of a configuration).

    python -m experiments.realism_cost [--from results] [--figure FILE.png]

prints the two generated blocks of docs/experiments.md from the committed results; the
figure the docs show is docs/img/experiments/realism-cost.png.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

from experiments.docfmt import Sweep, table
from experiments.stats import Comparison, describe, pairwise

ROOT = Path(__file__).resolve().parent.parent
OPTIONS = ("energy", "docks", "uncertainty", "radio", "all")
LABEL = {"all": "all four"}


@dataclass
class Config:
    """One configuration's makespans: policy → per-seed makespan (None: not every mineral
    delivered), over the seeds every configuration ran."""

    name: str
    sweep: Sweep
    makespans: dict[str, list[float | None]]

    def mean(self, policy: str) -> float:
        d = describe(self.makespans[policy])
        return d.mean if d.mean is not None else math.nan

    def incomplete(self, policy: str) -> int:
        return sum(v is None for v in self.makespans[policy])

    def ranking(self) -> list[str]:
        return sorted(self.makespans, key=self.mean)


def _by_seed(s: Sweep) -> dict[tuple[str, int], float | None]:
    out: dict[tuple[str, int], float | None] = {}
    for row in s.rows:
        done = row["completed"] == "true" and row["minerals_delivered"] == row["minerals_total"]
        out[(row["policy"], int(row["seed"]))] = float(row["makespan_s"]) if done else None
    return out


def load(out: Path) -> list[Config]:
    """The reference and every realism sweep present under `out`, aligned on common seeds."""
    sweeps = [("reference", Sweep(out / "reference"))]
    sweeps += [(o, Sweep(out / "realism" / o)) for o in OPTIONS if (out / "realism" / o).exists()]
    data = {name: _by_seed(s) for name, s in sweeps}
    seeds = sorted(set.intersection(*({seed for _, seed in d} for d in data.values())))
    policies = sweeps[0][1].policies
    return [
        Config(name, s, {p: [data[name].get((p, seed)) for seed in seeds] for p in policies})
        for name, s in sweeps
    ]


def _change(ref: Config, cfg: Config, policy: str) -> str:
    """Paired change of the mean makespan against the reference, in % with its 95 % CI."""
    diffs = [
        b - a
        for a, b in zip(ref.makespans[policy], cfg.makespans[policy], strict=True)
        if a is not None and b is not None
    ]
    d, base = describe(diffs), ref.mean(policy)
    if d.mean is None or d.ci_low is None or d.ci_high is None:
        return "n/a"
    return f"{d.mean / base:+.1%} [{d.ci_low / base:+.1%}, {d.ci_high / base:+.1%}]"


def cost_table(configs: list[Config]) -> str:
    """Mean makespan, paired change against the reference and rank, per policy × config."""
    ref = configs[0]
    rows = []
    for p in ref.makespans:
        row = [ref.sweep.short(p)]
        for c in configs:
            rank = c.ranking().index(p) + 1
            miss = f", {c.incomplete(p)} incomplete" if c.incomplete(p) else ""
            cost = "" if c is ref else f" ({_change(ref, c, p)})"
            row.append(f"{c.mean(p):.0f} s{cost} #{rank}{miss}")
        rows.append(row)
    head = ["policy"] + [LABEL.get(c.name, c.name) for c in configs]
    seeds = len(next(iter(ref.makespans.values())))
    note = (
        f"Mean makespan over seeds 0–{seeds - 1} (paired by seed), its change against the "
        "reference model with the 95 % CI of the paired mean difference, and the policy's "
        "rank by mean makespan within the configuration (#1 fastest)."
    )
    return note + "\n\n" + table(head, rows)


def _ordered(cmp: dict[tuple[str, str], Comparison], a: str, b: str) -> int:
    """+1 if a is significantly faster than b, −1 if significantly slower, 0 if undecided."""
    c = cmp.get((a, b))
    sign = 1
    if c is None:
        c, sign = cmp[(b, a)], -1
    if not c.significant or c.paired_mean_diff is None:
        return 0
    return sign * (1 if c.paired_mean_diff < 0 else -1)


def ranking(configs: list[Config]) -> str:
    """Each configuration's ranking, and every pair the option reverses significantly."""
    cmps = {c.name: {(x.a, x.b): x for x in pairwise(c.makespans, aligned=True)} for c in configs}
    ref = configs[0]
    lines, reversed_any = [], False
    for c in configs:
        order = " < ".join(c.sweep.short(p) for p in c.ranking())
        flips = []
        if c is not ref:
            for i, a in enumerate(ref.ranking()):
                for b in ref.ranking()[i + 1 :]:
                    before, after = _ordered(cmps[ref.name], a, b), _ordered(cmps[c.name], a, b)
                    if before * after < 0:
                        flips.append(f"{c.sweep.short(a)} and {c.sweep.short(b)}")
        reversed_any |= bool(flips)
        said = f"; reversed significantly: {', '.join(flips)}" if flips else ""
        lines.append(f"- **{LABEL.get(c.name, c.name)}**: {order}{said}")
    verdict = (
        "**Verdict:** some option reverses a significant order of the reference model (above)."
        if reversed_any
        else "**Verdict:** no option reverses any order that is significant under both "
        "models; where ranks move, the pair was not told apart under one of them."
    )
    return "\n".join(lines) + "\n\n" + verdict


def figure(configs: list[Config], path: Path) -> None:
    """Grouped bars: mean makespan with its 95 % CI per configuration, one bar per policy."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from engine import POLICIES

    policies = list(configs[0].makespans)
    fig, ax = plt.subplots(figsize=(10, 4.2))
    w = 0.8 / len(policies)
    for i, p in enumerate(policies):
        xs = [j + (i - len(policies) / 2 + 0.5) * w for j in range(len(configs))]
        stats = [describe(c.makespans[p]) for c in configs]
        ys = [d.mean or 0.0 for d in stats]
        es = [d.half_width or 0.0 for d in stats]
        cls = POLICIES.get(p)
        colour = cls.colour if cls else None
        ax.bar(xs, ys, w, yerr=es, label=configs[0].sweep.label(p), color=colour, capsize=2)
    ax.set_xticks(range(len(configs)), [LABEL.get(c.name, c.name) for c in configs])
    ax.set_ylabel("mean makespan (s, 95 % CI)")
    ax.set_title("The cost of each realism option on each policy")
    ax.legend(ncol=4, fontsize=8, loc="upper left")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--from", dest="src", type=Path, default=ROOT / "results")
    ap.add_argument("--figure", type=Path, default=None)
    a = ap.parse_args(argv)
    configs = load(a.src)
    print(cost_table(configs) + "\n\n" + ranking(configs))
    if a.figure:
        figure(configs, a.figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
