"""report.md: run status, the results table, the figures and a plain-language verdict each.

A verdict names the policy with the lowest mean, then says for every other policy whether
the difference is significant by the design's test — the paired t-test on per-seed
differences when the policies ran the same seeds (a sweep's design), else Welch — with its
p-value Holm-adjusted over the verdict family (summary.json `correction`). It says "no
significant difference" whenever that is the honest reading, flags when the rank test
(Wilcoxon, or Mann–Whitney) disagrees, and gives the unpaired Welch result as secondary;
every p-value printed is labelled raw or adjusted."""

from __future__ import annotations

from typing import Any

from experiments.figures import FigureSpec
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


def seeds_phrase(best: str, lower: int, other_lower: int, n: int) -> str:
    """How the seeds split between the best policy and another: "P1 lower on 3 of 5 seeds
    (equal on 1)", or, when every seed is equal, "an exact tie: equal on 5 of 5 seeds"."""
    equal = n - lower - other_lower
    if equal == n:
        return f"an exact tie: equal on {n} of {n} seeds"
    return f"{best} lower on {lower} of {n} seeds" + (f" (equal on {equal})" if equal else "")


def _pair(pairs: list[dict[str, Any]], a: str, b: str) -> tuple[dict[str, Any], int] | None:
    """The comparison of a and b, with the sign that turns its a−b effect into a's view."""
    for c in pairs:
        if c["a"] == a and c["b"] == b:
            return c, 1
        if c["a"] == b and c["b"] == a:
            return c, -1
    return None


TEST_NAMES = {
    "paired_t": "paired t",
    "wilcoxon": "Wilcoxon",
    "welch": "Welch",
    "mwu": "Mann–Whitney",
}


def panel_verdict(
    spec: SweepSpec, summary: dict[str, Any], column: str, quantity: str, unit: str
) -> str:
    metric = summary["metrics"].get(column)
    if metric is None:
        return f"No run reported {quantity}."
    per = metric["per_policy"]
    have = [p for p in spec.policies if per[p.name]["mean"] is not None]
    if not have:
        return f"No run reported {quantity}."
    best = min(have, key=lambda p: (per[p.name]["mean"], p))
    d = per[best.name]
    word = "shortest" if unit == "s" else "lowest"
    half = None if d["ci95"][1] is None else d["ci95"][1] - d["mean"]
    digits = 2 if abs(d["mean"]) < 10 else 1
    spread = f" ± {fmt_num(half, digits)}" if half is not None else ""
    mean = fmt_num(d["mean"], digits)
    head = f"{best.label} has the {word} mean {quantity} ({mean}{spread} {unit}"
    head += ", 95% CI)." if half is not None else f", n={d['n']})."
    head += _incomplete_note(spec, summary)
    if len(have) == 1:
        return head
    primary: tuple[list[str], list[str]] = ([], [])
    welch: tuple[list[str], list[str]] = ([], [])
    alpha = summary["alpha"]
    tests = set()
    for other in have:
        found = _pair(metric["pairwise"], best.name, other.name) if other != best else None
        if found is None:
            continue
        c, sign = found
        test, check = c["primary_test"], "wilcoxon" if c["primary_test"] == "paired_t" else "mwu"
        tests.add(test)
        p = c[f"{test}_p_adj"]
        if test == "paired_t":
            ci = c["paired_ci95"]
            lo, hi = sorted(-sign * v for v in ci) if None not in ci else (None, None)
            lower = c["a_lower"] if sign == 1 else c["b_lower"]
            other_lower = c["b_lower"] if sign == 1 else c["a_lower"]
            n = c["n_pairs"]
            if lower == other_lower == 0:  # every seed equal: no difference or interval to give
                eff = f", {other.short} and {best.short} {seeds_phrase('', 0, 0, n)}"
            else:
                diff = _signed(-sign * c["paired_mean_diff"], digits)
                eff = f", per-seed {other.short}−{best.short} {diff} {unit}"
                eff += "" if lo is None or hi is None else f" ({_ci(lo, hi, digits)})"
                eff += f", {seeds_phrase(best.short, lower, other_lower, n)}"
        else:
            eff = "" if c["cohen_d"] is None else f", d={sign * c['cohen_d']:.2f}"
        note = ""
        cp = c[f"{check}_p_adj"]
        if cp is not None and (cp < alpha) != c["significant"]:
            note = f"; {TEST_NAMES[check]} {fmt_p(cp, 'adj')} disagrees"
        primary[0 if c["significant"] else 1].append(
            f"{other.label} ({fmt_p(p, 'adj')}{eff}{note})"
        )
        if test == "paired_t" and c["welch_p_adj"] is not None:
            welch[0 if c["significant_welch"] else 1].append(
                f"{other.short} ({fmt_p(c['welch_p_adj'], 'adj')})"
            )
    if not (primary[0] or primary[1]):
        return head
    name = (
        "Paired by seed (paired t on per-seed differences, Holm-adjusted over the verdict family)"
        if tests == {"paired_t"}
        else "By Welch's t-test (Holm-adjusted over the verdict family)"
    )
    parts = [head, _tests_sentence(name, *primary)]
    if welch[0] or welch[1]:
        parts.append(_tests_sentence("Secondary, unpaired (Welch)", *welch))
    return " ".join(parts)


def _signed(x: float, digits: int) -> str:
    text = fmt_num(x, digits)
    return ("+" if x > 0 and text.strip("0.,") else "") + text


def _ci(lo: float, hi: float, digits: int) -> str:
    return f"95% CI {fmt_num(lo, digits)} to {fmt_num(hi, digits)}"


def _incomplete_note(spec: SweepSpec, summary: dict[str, Any]) -> str:
    """Warn, in every verdict, that runs which did not complete are not in the means."""
    missing = {k: len(v) for k, v in summary.get("not_completed", {}).items() if v}
    if not missing:
        return ""
    which = _join([f"{spec.policy(k).short}: {n}" for k, n in missing.items()])
    return (
        f" Runs that did not complete ({which}) are left out of these statistics, which "
        "flatters the policies they belong to; see Run status."
    )


def _tests_sentence(test: str, sig: list[str], nonsig: list[str]) -> str:
    if sig and nonsig:
        return (
            f"{test}, it is significantly lower than {_join(sig)}, with no significant "
            f"difference to {_join(nonsig)}."
        )
    if sig:
        return f"{test}, it is significantly lower than {_join(sig)}."
    return f"{test}, there is no significant difference to {_join(nonsig)}."


def _join(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def verdict(fs: FigureSpec, summary: dict[str, Any], spec: SweepSpec) -> list[str]:
    """A few sentences per panel of a figure."""
    out = []
    for panel in fs.panels:
        quantity = f"{panel.noun} {fs.quantity}" if panel.noun else fs.quantity
        out.append(panel_verdict(spec, summary, panel.column, quantity, fs.unit))
    return out


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
