"""The generated blocks of docs/experiments.md and docs/policies.md, rendered from the sweeps
`experiments.reproduce` runs. Every measured number in those two docs comes from here."""

from __future__ import annotations

import functools
from collections import Counter
from collections.abc import Callable
from pathlib import Path

from experiments import realism_cost
from experiments.docfmt import Sweep, last_found, mean, num, pm, pval, table
from experiments.policyblocks import (
    STUDY,
    ablations,
    central,
    lookahead,
    offline_reference,
    policies_reference,
    strict_vs_relaxed,
    why_p2,
)

REFERENCE_ROWS = (
    ("makespan (s)", "makespan_s", 1),
    ("makespan / per-run lower bound", "makespan_ratio", 2),
    ("makespan / a-priori lower bound", "makespan_ratio_apriori", 2),
    ("distance, scouts (m)", "distance_scout", 1),
    ("distance, excavators (m)", "distance_excavator", 1),
    ("distance, haulers (m)", "distance_hauler", 1),
    ("distance, total (m)", "distance_total", 1),
    ("auction open, scout→excavator (s, per-run mean)", "auction_open_s_scout_excavator_mean", 1),
    ("auction open, excavator→hauler (s, per-run mean)", "auction_open_s_excavator_hauler_mean", 1),
    ("auctions", "auctions", 1),
    ("bids", "bids", 1),
    ("declines", "declines", 1),
    ("re-announcements", "reannouncements", 1),
    ("bus messages", "messages", 1),
)
STATE_ROWS = (
    ("excavator", "idle", "no task"),
    ("excavator", "travelling", "driving to a site"),
    ("excavator", "digging", ""),
    ("excavator", "waiting", "full bucket, no hauler beside it"),
    ("excavator", "loading", "emptying the bucket into a bin"),
    ("hauler", "idle", "no task"),
    ("hauler", "travelling", "to a site, or after its partner"),
    ("hauler", "waiting", "at a site for a bucket, the transfer included"),
    ("hauler", "carrying", "to the plant"),
    ("hauler", "unloading", ""),
)
FINDINGS = (
    ("F1", "Policy 1 takes the least time", "makespan_s", "fcfs", "lowest"),
    ("F2", "excavators travel least under Policy 3", "distance_excavator", "nearest", "lowest"),
    (
        "F3",
        "Policy 2 has the longest excavator→hauler auction open times",
        "auction_open_s_excavator_hauler_mean",
        "coalition",
        "highest",
    ),
)
GRIDS = ("grid-speeds", "grid-dig-scouts", "grid-team", "grid-bid-sites")


def render_blocks(out: Path) -> dict[str, str]:
    """NAME → Markdown for every generated block, from the sweeps in `out`."""
    ref, held = Sweep(out / "reference"), Sweep(out / "heldout")
    abl = Sweep(out / "ablations")
    blocks: dict[str, Callable[[], str]] = {
        "reference-meta": lambda: reference_meta(ref),
        "reference-table": lambda: reference_table(ref),
        "reference-makespan": lambda: makespan_verdicts(ref),
        "reference-time-in-state": lambda: time_in_state(ref, ref.policies),
        "reference-tail": lambda: tail(ref),
        "reference-bound": lambda: bound(ref),
        "findings-verdicts": lambda: findings(ref, held),
        "findings-mechanism": lambda: mechanism(ref, held),
        "policies-reference": lambda: policies_reference(ref),
        "policies-strict-vs-relaxed": lambda: strict_vs_relaxed(ref),
        "policies-why-p2": lambda: why_p2(ref),
        "policies-lookahead": lambda: lookahead(ref),
        "policies-ablations": lambda: ablations(ref, abl),
        "policies-central": lambda: central(ref),
        "reference-offline": lambda: offline_reference(ref),
    }
    for g in GRIDS:
        blocks[g] = lambda g=g: grid(Sweep(out / g), g)  # type: ignore[misc]
    blocks["grid-findings"] = lambda: grid_findings([Sweep(out / g) for g in GRIDS])
    realism = functools.cache(lambda: realism_cost.load(out))  # two blocks, six sweeps
    blocks["realism-cost"] = lambda: realism_cost.cost_table(realism())
    blocks["realism-ranking"] = lambda: realism_cost.ranking(realism())
    rendered = {}
    for name, fn in blocks.items():
        text = fn()
        rendered[name] = text if text.endswith("\n") else text + "\n"
    return rendered


# --- the reference sweep -----------------------------------------------------------------
def reference_meta(s: Sweep) -> str:
    st = s.summary
    pols = ",".join(str(p["number"]) if p["number"] else p["name"] for p in st["policies"])
    return (
        f"```bash\nregolith sweep --policies {pols} --seeds {s.seed_text.replace('–', '-')} "
        "--out sweeps/reference\n```\n\n"
        f"Reference scenario, seeds {s.seed_text}, "
        f"{len(s.policies)} policies, {st['runs']} runs, {st['completed_runs']} completed. "
        "Mean ± half-width of the 95% CI over the completed runs of each policy:\n"
    )


def reference_table(s: Sweep) -> str:
    pols = s.policies
    best = min(pols, key=lambda p: s.stat("makespan_s", p))
    rows = []
    for title, col, digits in REFERENCE_ROWS:
        cells = []
        for p in pols:
            cell = pm(s, col, p, digits)
            cells.append(f"**{cell}**" if col == "makespan_s" and p == best else cell)
        rows.append([title, *cells])
    return table(["metric", *[s.label(p) for p in pols]], rows)


def _vs_best(s: Sweep, col: str, pols: list[str], unit: str, digits: int = 1) -> str:
    best = min(pols, key=lambda p: s.stat(col, p))
    rows = []
    for p in pols:
        if p == best:
            continue
        c = s.pair(col, p, best)
        lo, hi = c["paired_ci95"]
        rows.append(
            [
                s.label(p),
                f"{c['paired_mean_diff']:+,.{digits}f}",
                f"{lo:+,.{digits}f} to {hi:+,.{digits}f}",
                f"{c['b_lower']} of {c['n_pairs']}",
                pval(c["paired_t_p_adj"]),
                pval(c["wilcoxon_p_adj"]),
                pval(c["welch_p_adj"]),
            ]
        )
    head = [
        f"policy − {s.short(best)} ({unit})",
        "mean",
        "95% CI",
        f"seeds {s.short(best)} lower",
        "paired t p_adj",
        "Wilcoxon p_adj",
        "Welch p_adj (secondary)",
    ]
    return table(head, rows)


def makespan_verdicts(s: Sweep) -> str:
    pols = s.policies
    best = min(pols, key=lambda p: s.stat("makespan_s", p))
    return (
        f"Lowest mean makespan: **{s.label(best)}**, {pm(s, 'makespan_s', best)} s. Every other "
        "policy against it on the same seeds (p-values Holm-adjusted over the sweep's verdict "
        f"family of {s.summary['correction']['family_size']} tests):\n\n"
        + _vs_best(s, "makespan_s", pols, "s")
    )


def time_in_state(s: Sweep, pols: list[str]) -> str:
    rows = []
    for rtype, state, what in STATE_ROWS:
        col = f"time_in_state_{rtype}_{state}"
        name = f"{rtype}s {state}" + (f" ({what})" if what else "")
        rows.append([name, *[num(s.stat(col, p), 0) for p in pols]])
    return table(["robot-seconds per run (mean)", *[s.short(p) for p in pols]], rows)


def tail(s: Sweep) -> str:
    rows = []
    for p in s.policies:
        found = s.mean_of(p, last_found)
        after = s.mean_of(p, lambda r: float(r["makespan_s"]) - last_found(r))
        rows.append(
            [
                s.short(p),
                f"{num(mean(found), 0)} ({num(min(found), 0)}–{num(max(found), 0)})",
                f"{num(mean(after), 0)} ({num(min(after), 0)}–{num(max(after), 0)})",
            ]
        )
    return table(
        ["policy", "last site found (s): mean (range)", "then to the last delivery (s)"], rows
    )


def bound(s: Sweep) -> str:
    rows = []
    above = total = 0
    for p in s.policies:
        ratio = s.mean_of(p, lambda r: float(r["makespan_ratio"]))
        terms = Counter(s.mean_of(p, lambda r: r["lower_bound_term"]))
        above += sum(
            s.mean_of(p, lambda r: float(r["lower_bound_s"]) >= float(r["lower_bound_apriori_s"]))
        )
        total += len(ratio)
        rows.append(
            [
                s.short(p),
                f"{mean(ratio):.2f} ({min(ratio):.2f}–{max(ratio):.2f})",
                f"{s.stat('makespan_ratio_apriori', p):.2f}",
                ", ".join(f"{t} {n}" for t, n in sorted(terms.items(), key=lambda x: -x[1])),
            ]
        )
    return table(
        ["policy", "makespan / per-run bound: mean (range)", "/ a-priori bound", "binding term"],
        rows,
    ) + (f"\nThe per-run bound was at or above the a-priori one on {above} of {total} runs.\n")


# --- the study's findings -----------------------------------------------------------------
def _finding_verdict(s: Sweep, col: str, claimed: str, sense: str) -> tuple[str, str]:
    others = [p for p in STUDY if p != claimed]
    sign = 1 if sense == "lowest" else -1
    order = sorted(STUDY, key=lambda p: sign * s.stat(col, p))
    parts: list[str] = []
    beats: list[str] = []
    loses: list[str] = []
    for o in others:
        c = s.pair(col, claimed, o)
        d, p = c["paired_mean_diff"], c["paired_t_p_adj"]
        sig = p is not None and p < s.summary["alpha"]
        if sig and sign * d < 0:
            beats.append(s.short(o))
        if sig and sign * d > 0:
            loses.append(s.short(o))
        ahead = c["a_lower"] if sense == "lowest" else c["b_lower"]
        parts.append(
            f"vs {s.short(o)} {d:+,.1f} (p_adj {pval(p)}; ahead on {ahead} of {c['n_pairs']})"
        )
    if len(beats) == len(others):
        verdict = "**confirmed**"
    elif loses:
        verdict = f"**refuted**: {' and '.join(loses)} significantly ahead"
    elif beats:
        verdict = f"not confirmed: ahead of {' and '.join(beats)} only"
    else:
        verdict = "not confirmed: no significant difference"
    rank_text = (" < " if sign > 0 else " > ").join(s.short(p) for p in order)
    means = ", ".join(f"{s.short(p)} {num(s.stat(col, p))}" for p in STUDY)
    return verdict, f"{means}; {rank_text}; {s.short(claimed)} {'; '.join(parts)}"


def findings(ref: Sweep, held: Sweep) -> str:
    rows = []
    for key, claim, col, claimed, sense in FINDINGS:
        for s, which in ((ref, f"seeds {ref.seed_text}"), (held, f"held-out {held.seed_text}")):
            verdict, detail = _finding_verdict(s, col, claimed, sense)
            rows.append([f"{key}: {claim}", which, verdict, detail])
    relaxed = ", ".join(
        f"{s.seed_text}: {num(s.stat('makespan_s', 'coalition-relaxed'))} s"
        for s in (ref, held)
        if "coalition-relaxed" in s.policies
    )
    return table(
        ["finding (the study)", "seeds", "Regolith", "means; order; paired differences"], rows
    ) + (f"\nFor context, `coalition-relaxed` (number 5) has mean makespan {relaxed}.\n")


def mechanism(ref: Sweep, held: Sweep) -> str:
    out = []
    for s in (ref, held):
        pols = [p for p in (*STUDY, "coalition-relaxed") if p in s.policies]
        minerals = s.stat("minerals_total", pols[0])
        extra = [
            [
                "excavator wait per mineral (s)",
                *[num(s.stat("time_in_state_excavator_waiting", p) / minerals) for p in pols],
            ],
            ["makespan (s)", *[num(s.stat("makespan_s", p)) for p in pols]],
        ]
        body = time_in_state(s, pols).rstrip("\n").split("\n")
        body[0] = body[0].replace("robot-seconds per run (mean)", f"seeds {s.seed_text}")
        out.append("\n".join(body + ["| " + " | ".join(r) + " |" for r in extra]) + "\n")
    return "\n".join(out)


# --- the sensitivity grids ---------------------------------------------------------------
def _holds(s: Sweep, point: dict, key: str, claimed: str) -> bool:  # type: ignore[type-arg]
    w = point["winners"].get(key)
    return bool(w and w["policy"] == claimed and w["significant"])


def _f3(point: dict) -> bool:  # type: ignore[type-arg]
    m = point["summary"]["metrics"].get("auction_open_s_excavator_hauler_mean")
    if m is None:
        return False
    per = m["per_policy"]
    top = max(STUDY, key=lambda p: per[p]["mean"] if per[p]["mean"] is not None else -1.0)
    if top != "coalition":
        return False
    for c in m["pairwise"]:
        if "coalition" in (c["a"], c["b"]) and not c["significant"]:
            return False
    return True


def grid(s: Sweep, name: str) -> str:
    st = s.summary
    pa, pb = st["grid"]["parameters"]
    va, vb = st["grid"]["values"][pa], st["grid"]["values"][pb]
    cells: dict[tuple[str, str], str] = {}
    for pt in st["points"]:
        a, b = str(pt["values"][pa]), str(pt["values"][pb])
        parts = []
        for key in ("makespan", "excavator_distance"):
            w = pt["winners"][key]
            parts.append(s.short(w["policy"]) + ("" if w["significant"] else " (n.s.)"))
        cells[(a, b)] = " · ".join(parts)
    rows = [[f"{pa} = {a}", *[cells[(str(a), str(b))] for b in vb]] for a in va]
    return (
        f"Winner of makespan · of excavator distance per point ({name}, seeds {s.seed_text}, "
        "n.s.: not significantly ahead of the runner-up):\n\n"
        + table([f"{pa} \\ {pb}", *[f"{pb} = {b}" for b in vb]], rows)
    )


def grid_findings(sweeps: list[Sweep]) -> str:
    rows = []
    for s in sweeps:
        pts = s.summary["points"]
        f1 = [pt for pt in pts if _holds(s, pt, "makespan", "fcfs")]
        f2 = [pt for pt in pts if _holds(s, pt, "excavator_distance", "nearest")]
        f3 = [pt for pt in pts if _f3(pt)]

        def where(sel: list[dict], n: int = len(pts)) -> str:  # type: ignore[type-arg]
            inner = "; ".join(
                ", ".join(f"{k.split('.')[-1]} {v}" for k, v in pt["values"].items()) for pt in sel
            )
            return f"{len(sel)} of {n}" + (f" ({inner})" if inner else "")

        params = " × ".join(s.summary["grid"]["parameters"])
        rows.append([params, where(f1), where(f2), where(f3)])
    return table(
        [
            "grid",
            "F1 holds (P1 significantly fastest)",
            "F2 holds (P3 significantly least excavator distance)",
            "F3 holds (P2 significantly longest excavator→hauler auctions)",
        ],
        rows,
    )
