"""summary.json: per policy and metric the descriptive statistics, per metric the pairwise tests.

Everything here is a pure function of the runs, so the same journal gives the same summary
(apart from the `compute` section, which records how long the runs took on their machines).

Statistics are over completed runs. A run that did not complete (status `timeout` at the
scenario's max_time_s, or `stalled`) has no makespan, and its other metrics measure a cut-off
mission, so it enters no mean and no test; it is counted per policy and status, and its seed
listed, under `status` and `not_completed` (report.md shows both beside the results).

The p-values that decide verdicts are Holm-adjusted over one family: every pair of policies
on every metric a figure draws a verdict on (`correction`). Other metrics are adjusted over
their own pairs only. Every p-value key says which it is: `<test>_p_raw` or `<test>_p_adj`.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

from experiments.figures import figure_specs
from experiments.spec import SweepSpec
from experiments.stats import ALPHA, CONFIDENCE, Comparison, adjust_family, describe, pairwise
from experiments.table import Scalar, numeric_columns

SCHEMA = 2
COMPLETED = "completed"


def is_completed(row: dict[str, Scalar]) -> bool:
    """A run without a status (an engine that did not report one) counts as completed."""
    return str(row.get("status", COMPLETED)) == COMPLETED


def completed_rows(rows: list[dict[str, Scalar]]) -> list[dict[str, Scalar]]:
    """The runs the statistics are over."""
    return [r for r in rows if is_completed(r)]


def verdict_columns(rows: list[dict[str, Scalar]]) -> list[str]:
    """The metrics a figure draws a verdict on: the correction family's metrics."""
    return [p.column for fs in figure_specs(numeric_columns(rows)) for p in fs.panels]


def groups_by_policy(
    spec: SweepSpec, rows: list[dict[str, Scalar]], column: str
) -> dict[str, list[float | None]]:
    """One value per seed of each policy (None where missing), aligned by seed across policies."""
    at = {s: i for i, s in enumerate(spec.seeds)}
    out: dict[str, list[float | None]] = {p.name: [None] * len(at) for p in spec.policies}
    for row in rows:
        v = row.get(column)
        i = at[int(row["seed"])]  # type: ignore[arg-type]
        out[str(row["policy"])][i] = None if v is None else float(v)  # type: ignore[arg-type]
    return out


def build_summary(
    spec: SweepSpec, rows: list[dict[str, Scalar]], records: list[dict[str, Any]]
) -> dict[str, Any]:
    done = completed_rows(rows)
    cols = numeric_columns(done)
    family = [c for c in verdict_columns(done) if c in cols]
    groups = {col: groups_by_policy(spec, done, col) for col in cols}
    tests: dict[str, list[Comparison]] = {
        col: pairwise(g, aligned=True) if len(g) > 1 else [] for col, g in groups.items()
    }
    # widen the verdict metrics' correction from their own pairs to all of them together
    for col, comps in zip(family, adjust_family([tests[c] for c in family]), strict=True):
        tests[col] = comps
    n_family = sum(len(tests[c]) for c in family)
    metrics: dict[str, Any] = {}
    for col in cols:
        in_family = col in family
        metrics[col] = {
            "per_policy": {name: describe(vals).to_dict() for name, vals in groups[col].items()},
            "correction": {
                "method": "holm",
                "family": "verdicts" if in_family else "metric",
                "size": n_family if in_family else len(tests[col]),
            },
            "pairwise": [c.to_dict() for c in tests[col]],
        }
    paired = any(c.paired_design for col in family for c in tests[col])
    walls = [float(r["run_wall_s"]) for r in records if r.get("run_wall_s") is not None]
    summary: dict[str, Any] = _finite(
        {
            "schema": SCHEMA,
            "scenario": {
                "name": getattr(spec.scenario, "name", None),
                "hash": spec.scenario_hash,
                "scale": spec.scale,
                "planner": spec.planner,
            },
            "policies": [
                {"number": p.number, "name": p.name, "label": p.label} for p in spec.policies
            ],
            "seeds": list(spec.seeds),
            "runs": len(rows),
            "completed_runs": len(done),
            "status": run_status(spec, rows),
            "not_completed": not_completed(spec, rows),
            "confidence": CONFIDENCE,
            "alpha": ALPHA,
            "design": "paired" if paired else "unpaired",
            "verdict_test": "paired_t" if paired else "welch",
            "correction": {
                "method": "holm",
                "family_metrics": family,
                "family_size": n_family,
                "note": "each test's p-values are Holm-adjusted over every pair of policies on "
                "every metric in family_metrics together; any other metric over its own pairs",
            },
            "tests": _method(paired, family, n_family, len(spec.policies)),
            "metrics": metrics,
            "compute": {
                "run_wall_s_total": round(sum(walls), 3),
                "run_wall_s_mean": round(sum(walls) / len(walls), 4) if walls else None,
            },
        }
    )
    return summary


def run_status(spec: SweepSpec, rows: list[dict[str, Scalar]]) -> dict[str, dict[str, int]]:
    """Per policy: runs per status (a run without a status counts as completed)."""
    out: dict[str, dict[str, int]] = {}
    for p in spec.policies:
        counts = Counter(str(r.get("status", COMPLETED)) for r in rows if r["policy"] == p.name)
        out[p.name] = dict(sorted(counts.items()))
    return out


def not_completed(spec: SweepSpec, rows: list[dict[str, Scalar]]) -> dict[str, list[Any]]:
    """Per policy: the seeds (and statuses) of runs left out of the statistics."""
    out: dict[str, list[Any]] = {p.name: [] for p in spec.policies}
    for r in rows:
        if not is_completed(r):
            out[str(r["policy"])].append({"seed": r["seed"], "status": r.get("status")})
    return out


def _method(paired: bool, family: list[str], n_family: int, k: int) -> str:
    lead = (
        "Every policy runs the same seeds (the same worlds), so the design is paired: verdicts "
        "use the two-sided paired t-test on the per-seed differences, with the Wilcoxon "
        "signed-rank test as a check (flagged where it disagrees). The unpaired Welch t-test "
        "and Mann–Whitney U are secondary (reported, never the verdict)"
        if paired
        else "Verdicts use the two-sided Welch t-test, with Mann–Whitney U as a check"
    )
    fam = (
        f"Each test's p-values are Holm-adjusted over one family of {n_family} comparisons: "
        f"the {k * (k - 1) // 2} pairs of policies on each of the {len(family)} metrics with a "
        f"verdict ({', '.join(family)}); every other metric over its own pairs. Keys ending "
        "in _p_raw are unadjusted, _p_adj adjusted"
    )
    return (
        f"{lead}. {fam}. Effect sizes: Cohen's d (pooled sd) and rank-biserial r, positive "
        "when policy a is larger; paired: mean and 95% CI of the per-seed difference a−b. "
        "Statistics are over completed runs only; runs that timed out or stalled are counted "
        "per policy under status and not_completed"
    )


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: write null instead of an invalid file."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
