"""The plain-language verdict under each figure of report.md (`experiments/report.py`).

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
from experiments.report import fmt_num, fmt_p
from experiments.spec import SweepSpec


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
