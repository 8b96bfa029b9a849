"""Everything a finished sweep writes next to its journal: runs.csv, summary, figures, report."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from experiments.bound import BoundFn, bound_columns
from experiments.figures import (
    FigureSpec,
    PairedDiff,
    build_paired_figure,
    draw,
    figure_specs,
    save,
)
from experiments.journal import write_atomic
from experiments.report import fmt_num, fmt_p, render_report
from experiments.spec import SweepSpec
from experiments.stats import paired_diffs
from experiments.summary import build_summary, completed_rows, groups_by_policy
from experiments.table import numeric_columns, run_rows, write_csv
from experiments.verdict import seeds_phrase, verdict

FIG_DIR = "figures"


def write_outputs(
    spec: SweepSpec,
    records: list[dict[str, Any]],
    out_dir: Path,
    bound_fn: BoundFn | None = None,
) -> list[Path]:
    """Regenerate every derived file from the journal's records (idempotent).

    With `bound_fn` (the engine's world → makespan lower bound) each run also gets the
    per-run bound (lower_bound_s, makespan_ratio: the run's own discovery times) and the
    a-priori one (lower_bound_apriori_s, makespan_ratio_apriori), and bounds.csv lists every
    a-priori term per seed.
    """
    out_dir = Path(out_dir)
    rows = run_rows(spec, records)
    files = [out_dir / "runs.csv"]
    if bound_fn is not None:
        files.append(out_dir / "bounds.csv")
        write_csv(bound_columns(rows, spec.scenario, bound_fn), files[-1])
    write_csv(rows, files[0])
    summary = build_summary(spec, rows, records)
    done = completed_rows(rows)  # the figures show what the statistics are over
    labels = {p.name: p.label for p in spec.policies}
    figures = []
    for fs in figure_specs(numeric_columns(done)):
        data = {
            panel.column: {
                labels[name]: vals
                for name, vals in groups_by_policy(spec, done, panel.column).items()
            }
            for panel in fs.panels
        }
        paths = draw(fs, data, out_dir / FIG_DIR)
        files.extend(paths)
        figures.append(
            {
                "name": fs.name,
                "title": fs.title,
                "png": f"{FIG_DIR}/{fs.name}.png",
                "svg": f"{FIG_DIR}/{fs.name}.svg",
                "columns": [p.column for p in fs.panels],
                "verdict": verdict(fs, summary, spec),
            }
        )
        if fs.name == "makespan" and summary["design"] == "paired":
            entry = paired_figure(spec, summary, done, fs, out_dir / FIG_DIR)
            if entry is not None:
                files.extend(out_dir / entry[k] for k in ("png", "svg"))
                figures.append(entry)
    summary["figures"] = figures
    write_atomic(out_dir / "summary.json", json.dumps(summary, indent=2, allow_nan=False) + "\n")
    write_atomic(out_dir / "report.md", render_report(spec, summary))
    files += [out_dir / "summary.json", out_dir / "report.md"]
    return files


def paired_figure(
    spec: SweepSpec,
    summary: dict[str, Any],
    rows: list[dict[str, Any]],
    fs: FigureSpec,
    fig_dir: Path,
) -> dict[str, Any] | None:
    """The per-seed differences of every policy from the best one on the figure's metric.

    The reference is the policy with the lowest mean (the one the verdict names); each other
    policy's strip holds (its value − the reference's) per seed both completed, with the mean
    difference, its 95% CI and the verdict test's adjusted p-value.
    """
    column = fs.panels[0].column
    metric = summary["metrics"].get(column)
    if metric is None:
        return None
    per = metric["per_policy"]
    have = [p for p in spec.policies if per[p.name]["mean"] is not None]
    if len(have) < 2:
        return None
    best = min(have, key=lambda p: (per[p.name]["mean"], p))
    groups = groups_by_policy(spec, rows, column)
    comps, sentences = [], []
    for other in have:
        if other == best:
            continue
        c = next(c for c in metric["pairwise"] if {c["a"], c["b"]} == {best.name, other.name})
        sign = 1 if c["a"] == other.name else -1  # the stored a−b as other − best
        lo, hi = c["paired_ci95"]
        ci = (None, None) if lo is None else tuple(sorted((sign * lo, sign * hi)))
        lower = c["b_lower"] if sign == 1 else c["a_lower"]  # seeds where best is lower
        other_lower = c["a_lower"] if sign == 1 else c["b_lower"]
        tie = lower == other_lower == 0  # equal on every seed
        split = seeds_phrase(best.short, lower, other_lower, c["n_pairs"])
        p_adj = fmt_p(c["paired_t_p_adj"], "adj")
        diffs = paired_diffs(groups[other.name], groups[best.name])
        comps.append(
            PairedDiff(
                other.label,
                list(diffs),
                ci,
                f"{p_adj}\n"
                + (
                    f"equal {c['n_pairs']}/{c['n_pairs']}"
                    if tie
                    else f"{best.short} lower {lower}/{c['n_pairs']}"
                ),
                spec.policies.index(other),
            )
        )
        mean = c["paired_mean_diff"]
        word = "higher" if (mean or 0) * sign > 0 else "lower"
        span = "" if ci[0] is None else f" (95% CI {fmt_num(ci[0])} to {fmt_num(ci[1])})"
        differs = (
            f"{split}"
            if tie
            else f"{fmt_num(abs(sign * mean))} {fs.unit} {word} on average per seed{span}; {split}"
        )
        sentences.append(
            f"{other.label} − {best.label}: {differs}; "
            f"paired t {p_adj}, Wilcoxon {fmt_p(c['wilcoxon_p_adj'], 'adj')} (Holm-adjusted "
            "over the verdict family)."
        )
    name = f"{fs.name}_paired"
    fig = build_paired_figure(
        f"{fs.title}: difference from {best.label}\non the same seed",
        fs.quantity,
        fs.unit,
        best.short,
        comps,
    )
    save(fig, name, fig_dir)
    return {
        "name": name,
        "title": f"{fs.title}: paired differences by seed",
        "png": f"{FIG_DIR}/{name}.png",
        "svg": f"{FIG_DIR}/{name}.svg",
        "columns": [column],
        "caption": f"dots: seeds, each policy's value minus {best.label}'s on the same seed "
        "(above the line: higher than it); diamond: mean difference with its 95% CI (paired t).",
        "verdict": sentences,
    }
