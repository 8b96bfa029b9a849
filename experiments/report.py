"""report.md: run status, the results table, the figures and a plain-language verdict each
(written by `experiments/verdict.py`); the number formats both use."""

from __future__ import annotations

from typing import Any

from experiments.spec import SweepSpec


def fmt_p(p: float | None, kind: str = "") -> str:
    """`kind` labels the p-value in prose: 'adj' → p_adj=…, 'raw' → p_raw=…; '' → bare."""
    if p is None:
        return "n/a"
    name = f"p_{kind}" if kind else "p"
    return f"{name}<0.0001" if p < 1e-4 else f"{name}={p:.2g}" if p < 0.01 else f"{name}={p:.3f}"


def fmt_pv(p: float | None) -> str:
    """A p-value in a table cell (the column header says raw or adjusted)."""
    if p is None:
        return "n/a"
    return "<0.0001" if p < 1e-4 else f"{p:.2g}" if p < 0.01 else f"{p:.3f}"


def fmt_num(x: float | None, digits: int | None = None) -> str:
    """Thousands separators; by default 1 decimal, 2 below 10 (ratios, short times)."""
    if x is None:
        return "–"
    if digits is None:
        digits = 2 if abs(x) < 10 else 1
    text = f"{x:,.{digits}f}" if abs(x) < 1e6 else f"{x:.3g}"
    return text[1:] if text.startswith("-") and not text.strip("-0.,") else text  # no "-0.0"


def seed_ranges(seeds: tuple[int, ...] | list[int]) -> str:
    """[0,1,2,5,7,8] → '0-2,5,7-8' (the --seeds syntax)."""
    parts: list[str] = []
    ordered = sorted(seeds)
    i = 0
    while i < len(ordered):
        j = i
        while j + 1 < len(ordered) and ordered[j + 1] == ordered[j] + 1:
            j += 1
        parts.append(str(ordered[i]) if i == j else f"{ordered[i]}-{ordered[j]}")
        i = j + 1
    return ",".join(parts)


def command(spec: SweepSpec) -> str:
    pols = ",".join(str(p.number) if p.number else p.name for p in spec.policies)
    cmd = f"regolith sweep --policies {pols} --seeds {seed_ranges(spec.seeds)}"
    if getattr(spec.scenario, "name", "reference") != "reference" and spec.scale == 1:
        cmd += " --scenario FILE"
    if spec.scale > 1:
        cmd += f" --scale {spec.scale}"
    if spec.planner != "ompl":
        cmd += f" --planner {spec.planner}"
    return cmd + " --out DIR"


def _table(spec: SweepSpec, summary: dict[str, Any], columns: list[str]) -> list[str]:
    head = "| metric | " + " | ".join(p.label for p in spec.policies) + " |"
    lines = [head, "|" + " --- |" * (len(spec.policies) + 1)]
    status = summary.get("status", {})
    cells = []
    for p in spec.policies:
        counts = status.get(p.name, {})
        total = sum(counts.values())
        cells.append(f"{counts.get('completed', 0)} of {total}")
    lines.append("| runs completed (the statistics' n) | " + " | ".join(cells) + " |")
    for col in columns:
        per = summary["metrics"][col]["per_policy"]
        cells = []
        for p in spec.policies:
            d = per[p.name]
            if d["mean"] is None:
                cells.append("–")
            elif d["ci95"][0] is None:
                cells.append(fmt_num(d["mean"], 2))
            else:
                cells.append(f"{fmt_num(d['mean'], 2)} ± {fmt_num(d['ci95'][1] - d['mean'], 2)}")
        lines.append(f"| `{col}` | " + " | ".join(cells) + " |")
    return lines


def _status_lines(spec: SweepSpec, summary: dict[str, Any]) -> list[str]:
    """Run status per policy: completed, timed out, stalled; the seeds left out."""
    status, missing = summary.get("status", {}), summary.get("not_completed", {})
    kinds = sorted({k for v in status.values() for k in v if k != "completed"})
    head = "| policy | runs | completed | " + "".join(f"{k} | " for k in kinds)
    lines = [head + "seeds not completed |", "|" + " --- |" * (4 + len(kinds))]
    for p in spec.policies:
        counts = status.get(p.name, {})
        seeds = ", ".join(f"{m['seed']} ({m['status']})" for m in missing.get(p.name, []))
        lines.append(
            f"| {p.label} | {sum(counts.values())} | {counts.get('completed', 0)} | "
            + "".join(f"{counts.get(k, 0)} | " for k in kinds)
            + f"{seeds or '–'} |"
        )
    n_out = summary["runs"] - summary.get("completed_runs", summary["runs"])
    if n_out:
        note = (
            f"{n_out} of {summary['runs']} runs did not complete. They have no makespan (the "
            "mission did not finish by the scenario's max_time_s, or stalled) and their other "
            "metrics measure a cut-off mission, so every mean, interval and test below is over "
            "completed runs only, and a paired comparison uses only seeds both policies "
            "completed. Leaving them out flatters the policy that failed to finish: read each "
            "mean with its completed count."
        )
    else:
        note = f"All {summary['runs']} runs completed."
    return [*lines, "", note]


def _paired_table(spec: SweepSpec, summary: dict[str, Any], columns: list[str]) -> list[str]:
    labels = {p.name: p.short for p in spec.policies}
    lines = [
        "| metric | a vs b | seeds paired | mean a−b per seed (95% CI) | a lower / b lower "
        "| paired t p (raw) | paired t p (Holm adj.) | Wilcoxon p (raw) "
        "| Wilcoxon p (Holm adj.) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for col in columns:
        for c in summary["metrics"][col]["pairwise"]:
            lo, hi = c["paired_ci95"]
            ci = "" if lo is None else f" ({fmt_num(lo, 2)} to {fmt_num(hi, 2)})"
            star = " *" if c["significant_paired"] else ""
            lines.append(
                f"| `{col}` | {labels[c['a']]} vs {labels[c['b']]} | {c['n_pairs']}"
                f" | {fmt_num(c['paired_mean_diff'], 2)}{ci} | {c['a_lower']} / {c['b_lower']}"
                f" | {fmt_pv(c['paired_t_p_raw'])} | {fmt_pv(c['paired_t_p_adj'])}{star}"
                f" | {fmt_pv(c['wilcoxon_p_raw'])} | {fmt_pv(c['wilcoxon_p_adj'])} |"
            )
    return lines


def _unpaired_table(spec: SweepSpec, summary: dict[str, Any], columns: list[str]) -> list[str]:
    labels = {p.name: p.short for p in spec.policies}
    lines = [
        "| metric | a vs b | mean a−b | Welch p (raw) | Welch p (Holm adj.) "
        "| Mann–Whitney p (raw) | Mann–Whitney p (Holm adj.) | Cohen's d | r |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for col in columns:
        for c in summary["metrics"][col]["pairwise"]:
            d = "–" if c["cohen_d"] is None else f"{c['cohen_d']:.2f}"
            r = "–" if c["rank_biserial"] is None else f"{c['rank_biserial']:.2f}"
            star = " *" if c["significant_welch"] else ""
            lines.append(
                f"| `{col}` | {labels[c['a']]} vs {labels[c['b']]} | {fmt_num(c['mean_diff'], 2)}"
                f" | {fmt_pv(c['welch_p_raw'])} | {fmt_pv(c['welch_p_adj'])}{star}"
                f" | {fmt_pv(c['mwu_p_raw'])} | {fmt_pv(c['mwu_p_adj'])} | {d} | {r} |"
            )
    return lines


def _family_sentence(summary: dict[str, Any]) -> str:
    corr = summary["correction"]
    k = len(summary["policies"])
    metrics = ", ".join(f"`{m}`" for m in corr["family_metrics"]) or "none"
    return (
        f"Correction family: Holm over {corr['family_size']} comparisons — the "
        f"{k * (k - 1) // 2} pairs of policies on each of the {len(corr['family_metrics'])} "
        f"metrics with a verdict ({metrics}); each test is adjusted separately over this "
        "family. Columns say which p-values are raw and which Holm-adjusted."
    )


def render_report(spec: SweepSpec, summary: dict[str, Any]) -> str:
    scen = summary["scenario"]
    n_seeds = len(spec.seeds)
    paired = summary.get("design") == "paired"
    design = (
        "Design: paired — every policy ran the same seeds (the same worlds), so verdicts use "
        "the paired t-test on per-seed differences (Wilcoxon signed-rank as a check); Welch "
        "and Mann–Whitney are secondary."
        if paired
        else "Design: unpaired — verdicts use Welch's t-test (Mann–Whitney as a check)."
    )
    lines = [
        f"# Policy comparison: {scen['name']} scenario, {len(spec.policies)} policies × "
        f"{n_seeds} seeds",
        "",
        f"Scenario `{scen['name']}` (hash `{scen['hash']}`, scale {scen['scale']}, planner "
        f"{scen.get('planner', 'ompl')}), seeds "
        f"{seed_ranges(spec.seeds)}: {summary['runs']} runs. Means ± half-width of the 95% "
        f"t-interval over completed runs; significance at α={summary['alpha']} on "
        "Holm-adjusted p-values.",
        "",
        design,
        "",
        _family_sentence(summary),
        "",
        f"Regenerate: `{command(spec)}`",
        "",
        "## Run status",
        "",
        *_status_lines(spec, summary),
        "",
    ]
    key_cols = list(summary["correction"]["family_metrics"])
    lines += ["## Results", "", *_table(spec, summary, key_cols), ""]
    for f in summary["figures"]:
        caption = f.get(
            "caption",
            "box: quartiles and median over runs; dots: runs; diamond: mean with 95% CI.",
        )
        lines += [
            f"## {f['title']}",
            "",
            f"![{f['title']}]({f['png']})",
            "",
            f"[SVG]({f['svg']}) · {caption}",
            "",
        ]
        if len(f["verdict"]) == 1:
            lines += [f"**Verdict.** {f['verdict'][0]}", ""]
        else:
            lines += ["**Verdict.**", "", *[f"- {v}" for v in f["verdict"]], ""]
    paired_sec = [
        "## Paired tests by seed (the verdicts)" if paired else "## Paired tests by seed",
        "",
        "Per-seed differences a−b over the seeds both policies completed; `*`: paired t "
        "significant after adjustment. " + _family_sentence(summary),
        "",
        *_paired_table(spec, summary, key_cols),
        "",
    ]
    unpaired_sec = [
        "## Unpaired tests (secondary)" if paired else "## Unpaired tests (the verdicts)",
        "",
        "Runs as independent samples, ignoring that the policies share seeds; `*`: Welch "
        "significant after adjustment (same family).",
        "",
        *_unpaired_table(spec, summary, key_cols),
        "",
    ]
    lines += [*paired_sec, *unpaired_sec] if paired else unpaired_sec
    lines += [
        "## All metrics",
        "",
        "Metrics without a verdict: their tests, in summary.json, are Holm-adjusted over their "
        "own pairs only.",
        "",
        *_table(spec, summary, list(summary["metrics"])),
        "",
    ]
    lines += ["## Method", "", summary["tests"] + ".", ""]
    return "\n".join(lines)
