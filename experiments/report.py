"""report.md: the results table, the figures and a plain-language verdict for each figure.

A verdict names the policy with the lowest mean, then says for every other policy whether
the difference is significant (Holm-adjusted Welch p < α) or not. It says "no significant
difference" whenever that is the honest reading, and flags when Mann–Whitney disagrees.
"""

from __future__ import annotations

from typing import Any

from experiments.figures import FigureSpec
from experiments.spec import SweepSpec


def fmt_p(p: float | None) -> str:
    if p is None:
        return "n/a"
    return "p<0.0001" if p < 1e-4 else f"p={p:.2g}" if p < 0.01 else f"p={p:.3f}"


def fmt_num(x: float | None, digits: int | None = None) -> str:
    """Thousands separators; by default 1 decimal, 2 below 10 (ratios, short times)."""
    if x is None:
        return "–"
    if digits is None:
        digits = 2 if abs(x) < 10 else 1
    return f"{x:,.{digits}f}" if abs(x) < 1e6 else f"{x:.3g}"


def _pair(pairs: list[dict[str, Any]], a: str, b: str) -> tuple[dict[str, Any], int] | None:
    """The comparison of a and b, with the sign that turns its a−b effect into a's view."""
    for c in pairs:
        if c["a"] == a and c["b"] == b:
            return c, 1
        if c["a"] == b and c["b"] == a:
            return c, -1
    return None


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
    if len(have) == 1:
        return head
    welch: tuple[list[str], list[str]] = ([], [])
    pair: tuple[list[str], list[str]] = ([], [])
    alpha = summary["alpha"]
    for other in have:
        found = _pair(metric["pairwise"], best.name, other.name) if other != best else None
        if found is None:
            continue
        c, sign = found
        eff = "" if c["cohen_d"] is None else f", d={sign * c['cohen_d']:.2f}"
        mw = c["mwu_p_holm"]
        note = ""
        if mw is not None and (mw < alpha) != c["significant"]:
            note = f"; Mann–Whitney {fmt_p(mw)} disagrees"
        welch[0 if c["significant"] else 1].append(
            f"{other.label} ({fmt_p(c['welch_p_holm'])}{eff}{note})"
        )
        if c.get("paired_t_p_holm") is not None:
            wx = c.get("wilcoxon_p_holm")
            wnote = ""
            if wx is not None and (wx < alpha) != c["significant_paired"]:
                wnote = f"; Wilcoxon {fmt_p(wx)} disagrees"
            pair[0 if c["significant_paired"] else 1].append(
                f"{other.short} ({fmt_p(c['paired_t_p_holm'])}{wnote})"
            )
    parts = [head, _tests_sentence("Unpaired (Welch)", *welch)]
    if pair[0] or pair[1]:
        parts.append(_tests_sentence("Paired by seed (same worlds)", *pair))
    return " ".join(parts)


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
    return cmd + " --out DIR"


def _table(spec: SweepSpec, summary: dict[str, Any], columns: list[str]) -> list[str]:
    head = "| metric | " + " | ".join(p.label for p in spec.policies) + " |"
    lines = [head, "|" + " --- |" * (len(spec.policies) + 1)]
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


def _tests_table(spec: SweepSpec, summary: dict[str, Any], columns: list[str]) -> list[str]:
    labels = {p.name: p.short for p in spec.policies}
    lines = [
        "| metric | a vs b | mean a−b | Welch p | Mann–Whitney p | paired t p | Wilcoxon p "
        "| Cohen's d | r |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for col in columns:
        for c in summary["metrics"][col]["pairwise"]:
            d = "–" if c["cohen_d"] is None else f"{c['cohen_d']:.2f}"
            r = "–" if c["rank_biserial"] is None else f"{c['rank_biserial']:.2f}"
            star = " *" if c["significant"] else ""
            lines.append(
                f"| `{col}` | {labels[c['a']]} vs {labels[c['b']]} | {fmt_num(c['mean_diff'], 2)}"
                f" | {fmt_p(c['welch_p_holm'])}{star} | {fmt_p(c['mwu_p_holm'])}"
                f" | {fmt_p(c.get('paired_t_p_holm'))} | {fmt_p(c.get('wilcoxon_p_holm'))}"
                f" | {d} | {r} |"
            )
    return lines


def render_report(spec: SweepSpec, summary: dict[str, Any]) -> str:
    scen = summary["scenario"]
    n_seeds = len(spec.seeds)
    lines = [
        f"# Policy comparison: {scen['name']} scenario, {len(spec.policies)} policies × "
        f"{n_seeds} seeds",
        "",
        f"Scenario `{scen['name']}` (hash `{scen['hash']}`, scale {scen['scale']}), seeds "
        f"{seed_ranges(spec.seeds)}: {summary['runs']} runs. Means ± half-width of the 95% "
        f"t-interval over runs; significance at α={summary['alpha']} after Holm correction.",
        "",
        f"Regenerate: `{command(spec)}`",
        "",
    ]
    if summary["status"]:
        st = "; ".join(
            f"{spec.policy(k).label}: " + ", ".join(f"{n} {s}" for s, n in v.items())
            for k, v in summary["status"].items()
        )
        lines += [f"Run status: {st}.", ""]
    key_cols = [c for f in summary["figures"] for c in f["columns"]]
    lines += ["## Results", "", *_table(spec, summary, key_cols), ""]
    for f in summary["figures"]:
        lines += [
            f"## {f['title']}",
            "",
            f"![{f['title']}]({f['png']})",
            "",
            f"[SVG]({f['svg']}) · box: quartiles and median over runs; dots: runs; "
            "diamond: mean with 95% CI.",
            "",
        ]
        if len(f["verdict"]) == 1:
            lines += [f"**Verdict.** {f['verdict'][0]}", ""]
        else:
            lines += ["**Verdict.**", "", *[f"- {v}" for v in f["verdict"]], ""]
    lines += [
        "## Pairwise tests",
        "",
        "All p-values Holm-adjusted over the policy pairs of each metric; `*`: Welch "
        "significant. Paired tests match runs by seed (the same world for every policy).",
        "",
    ]
    lines += [*_tests_table(spec, summary, key_cols), ""]
    lines += ["## All metrics", "", *_table(spec, summary, list(summary["metrics"])), ""]
    lines += ["## Method", "", summary["tests"] + ".", ""]
    return "\n".join(lines)
