"""The generated blocks of docs/policies.md (and the offline reference's in
docs/experiments.md), rendered from the reference sweep and the ablations."""

from __future__ import annotations

from experiments.ablations import VARIANTS
from experiments.docfmt import Sweep, last_found, mean, num, pm, pval, table

STUDY = ("fcfs", "coalition", "nearest")


def policies_reference(s: Sweep) -> str:
    pols = s.policies
    best = min(pols, key=lambda p: s.stat("makespan_s", p))
    rows = [
        [
            "makespan (s), mean ± 95% CI",
            *[
                f"**{pm(s, 'makespan_s', p)}**" if p == best else pm(s, "makespan_s", p)
                for p in pols
            ],
        ],
        ["makespan / per-run lower bound", *[f"{s.stat('makespan_ratio', p):.2f}" for p in pols]],
        ["distance, total (m)", *[num(s.stat("distance_total", p)) for p in pols]],
    ]
    return f"Seeds {s.seed_text}:\n\n" + table(["", *[s.short(p) for p in pols]], rows)


def strict_vs_relaxed(s: Sweep) -> str:
    c = s.pair("makespan_s", "coalition", "coalition-relaxed")
    lo, hi = c["paired_ci95"]
    rows = [
        [
            "makespan (s), mean ± 95% CI",
            pm(s, "makespan_s", "coalition"),
            pm(s, "makespan_s", "coalition-relaxed"),
        ],
        [
            "paired difference, P2 − relaxed",
            f"{c['paired_mean_diff']:+,.1f} s (95% CI {lo:+,.1f} to {hi:+,.1f}), relaxed faster on "
            f"{c['b_lower']} of {c['n_pairs']} seeds, paired t p_adj {pval(c['paired_t_p_adj'])}",
            "",
        ],
        [
            "distance, excavators / haulers (m)",
            *[
                f"{num(s.stat('distance_excavator', p))} / {num(s.stat('distance_hauler', p))}"
                for p in ("coalition", "coalition-relaxed")
            ],
        ],
        [
            "excavator→hauler auction open (s, per-run mean)",
            *[
                pm(s, "auction_open_s_excavator_hauler_mean", p)
                for p in ("coalition", "coalition-relaxed")
            ],
        ],
        [
            "robot-seconds: excavators waiting / haulers idle",
            *[
                f"{num(s.stat('time_in_state_excavator_waiting', p), 0)} / "
                f"{num(s.stat('time_in_state_hauler_idle', p), 0)}"
                for p in ("coalition", "coalition-relaxed")
            ],
        ],
    ]
    rel = c["paired_mean_diff"] / s.stat("makespan_s", "coalition-relaxed") * 100
    return table(["", "Policy 2 (`coalition`, as specified)", "`coalition-relaxed`"], rows) + (
        f"\nThe strict rule's makespan is {rel:+.1f}% of the relaxed rule's.\n"
    )


def _tail_mean(s: Sweep, p: str) -> float:
    return mean(s.mean_of(p, lambda r: float(r["makespan_s"]) - last_found(r)))


def why_p2(s: Sweep) -> str:
    w = {p: s.stat("time_in_state_excavator_waiting", p) for p in STUDY}
    idle = {p: s.stat("time_in_state_hauler_idle", p) for p in STUDY}
    found = [x for p in STUDY for x in s.mean_of(p, last_found)]
    return (
        f"Measured on seeds {s.seed_text} (robot-seconds per mission, summed over the robots of "
        f"a type): under Policy 2 excavators spend {num(w['coalition'], 0)} s *waiting* with a "
        f"full bucket (Policy 1: {num(w['fcfs'], 0)} s, Policy 3: {num(w['nearest'], 0)} s) "
        f"while haulers spend {num(idle['coalition'], 0)} s *idle* (Policy 1: "
        f"{num(idle['fcfs'], 0)} s) — the robots that could empty those buckets are free, just "
        f"not there. The last site is found at {num(min(found), 0)}–{num(max(found), 0)} s "
        "(by the spiral, whatever the policy); under Policy 2 "
        f"{num(_tail_mean(s, 'coalition'), 0)} s pass on average from then to the last "
        f"delivery (Policy 1: {num(_tail_mean(s, 'fcfs'), 0)} s).\n"
    )


def lookahead(s: Sweep) -> str:
    c = s.pair("makespan_s", "lookahead", "coalition")
    diffs = [
        s.values("makespan_s", "coalition")[k] - v
        for k, v in s.values("makespan_s", "lookahead").items()
    ]
    dist = s.stat("distance_total", "lookahead") / s.stat("distance_total", "coalition")
    return (
        f"Over seeds {s.seed_text} Policy 4's mean makespan is "
        f"**{pm(s, 'makespan_s', 'lookahead')} s**, {num(-c['paired_mean_diff'])} s below Policy "
        f"2's {pm(s, 'makespan_s', 'coalition')} s: paired t-test p_adj "
        f"{pval(c['paired_t_p_adj'])}, Wilcoxon p_adj {pval(c['wilcoxon_p_adj'])}, Welch p_adj "
        f"{pval(c['welch_p_adj'])}; Policy 4 is faster on {c['a_lower']} of {c['n_pairs']} "
        f"seeds (by {num(min(diffs), 0)} to {num(max(diffs), 0)} s). Total distance is "
        f"**{dist:.3f}×** Policy 2's ({num(s.stat('distance_total', 'lookahead'), 0)} m vs "
        f"{num(s.stat('distance_total', 'coalition'), 0)} m). Excavators wait "
        f"{num(s.stat('time_in_state_excavator_waiting', 'lookahead'), 0)} s with a full bucket "
        f"(Policy 2: {num(s.stat('time_in_state_excavator_waiting', 'coalition'), 0)} s) and "
        f"haulers idle {num(s.stat('time_in_state_hauler_idle', 'lookahead'), 0)} s "
        f"({num(s.stat('time_in_state_hauler_idle', 'coalition'), 0)} s); the time from the "
        f"last site found to the last delivery falls from {num(_tail_mean(s, 'coalition'), 0)} "
        f"s to {num(_tail_mean(s, 'lookahead'), 0)} s; the ratio to the per-run lower bound "
        f"from {s.stat('makespan_ratio', 'coalition'):.2f} to "
        f"{s.stat('makespan_ratio', 'lookahead'):.2f}.\n"
    )


def ablations(ref: Sweep, abl: Sweep) -> str:
    """Each variant and the registered policies it changes, on the ablation sweep's seeds,
    against Policy 2 on the same seeds (the reference sweep's runs)."""
    seeds = set(abl.summary["seeds"])
    p2 = {k: v for k, v in ref.values("makespan_s", "coalition").items() if k in seeds}
    d2 = mean([v for k, v in ref.values("distance_total", "coalition").items() if k in seeds])

    def row(s: Sweep, name: str, what: str) -> list[str]:
        ms = {k: v for k, v in s.values("makespan_s", name).items() if k in seeds}
        ds = [v for k, v in s.values("distance_total", name).items() if k in seeds]
        diffs = [v - p2[k] for k, v in ms.items() if k in p2]
        return [
            what,
            num(mean(list(ms.values()))),
            f"{mean(diffs):+,.1f}",
            f"{sum(d < 0 for d in diffs)} of {len(diffs)}",
            f"{mean(ds) / d2:.3f}",
        ]

    central = "centralized greedy assignment with rules 1–3 (`central-greedy`)"
    rows = [row(ref, "lookahead", "Policy 4 as registered")]
    rows += [row(abl, n, VARIANTS[n][2]) for n in abl.policies if n != "central-greedy-no-lead"]
    rows.append(row(ref, "central-greedy", central))
    rows += [row(abl, n, VARIANTS[n][2]) for n in abl.policies if n == "central-greedy-no-lead"]
    head = ["variant", "makespan (s)", "vs Policy 2 (s)", "faster than P2 on", "distance"]
    return (
        f"Seeds {abl.seed_text}; vs Policy 2: the mean per-seed makespan difference; "
        "distance: total distance / Policy 2's.\n\n" + table(head, rows)
    )


def central(s: Sweep) -> str:
    c = s.pair("makespan_s", "central-greedy", "lookahead")
    return (
        f"`central-greedy`: {pm(s, 'makespan_s', 'central-greedy')} s against Policy 4's "
        f"{pm(s, 'makespan_s', 'lookahead')} s: mean per-seed difference "
        f"{c['paired_mean_diff']:+,.1f} s, paired t p_adj {pval(c['paired_t_p_adj'])}, Wilcoxon "
        f"p_adj {pval(c['wilcoxon_p_adj'])}; Policy 4 faster on {c['b_lower']} of "
        f"{c['n_pairs']} seeds.\n"
    )


def offline_reference(s: Sweep) -> str:
    """The clairvoyant reference against the best online policy and the greedy baseline."""
    pols = ("lookahead", "central-greedy", "offline")
    rows = [
        ["makespan (s), mean ± 95% CI", *(pm(s, "makespan_s", p) for p in pols)],
        [
            "per-run lower bound `lower_bound_s` (s), mean",
            *(num(s.stat("lower_bound_s", p)) for p in pols),
        ],
        [
            "makespan / per-run bound, mean (min)",
            *(
                f"{s.stat('makespan_ratio', p):.3f} "
                f"({min(s.values('makespan_ratio', p).values()):.4f})"
                for p in pols
            ),
        ],
    ]
    lines = [table(["", *(s.label(p) for p in pols)], rows).rstrip("\n"), ""]
    for other in ("lookahead", "central-greedy"):
        c = s.pair("makespan_s", other, "offline")
        lo, hi = c["paired_ci95"]
        lines.append(
            f"- {s.label(other)} − offline, paired by seed: {c['paired_mean_diff']:+,.1f} s "
            f"(95% CI {lo:+,.1f} to {hi:+,.1f}), paired t p_adj {pval(c['paired_t_p_adj'])}, "
            f"Wilcoxon p_adj {pval(c['wilcoxon_p_adj'])}; offline faster on {c['b_lower']} of "
            f"{c['n_pairs']} seeds."
        )
    mk, ratio = s.values("makespan_s", "offline"), s.values("makespan_ratio", "offline")
    held = sum(1 for v in ratio.values() if v >= 1.0)
    lines.append(f"- The per-run bound held on {held} of {len(ratio)} offline runs.")
    p4, p4_ratio = s.values("makespan_s", "lookahead"), s.values("makespan_ratio", "lookahead")
    lost = sorted(k for k in mk if k in p4 and mk[k] > p4[k])
    if lost:
        lost_text = "; ".join(
            f"seed {k}: {num(mk[k])} against {num(p4[k])} s, ratios to each run's own bound "
            f"{ratio[k]:.3f} against {p4_ratio[k]:.3f}"
            for k in lost
        )
        lines.append(f"- Seeds where Policy 4 is faster: {lost_text}.")
    return "\n".join(lines) + "\n"
