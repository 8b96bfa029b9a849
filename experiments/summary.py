"""summary.json: per policy and metric the descriptive statistics, per metric the pairwise tests.

Everything here is a pure function of the runs, so the same journal gives the same summary
(apart from the `compute` section, which records how long the runs took on their machines).
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

from experiments.spec import SweepSpec
from experiments.stats import ALPHA, CONFIDENCE, describe, pairwise
from experiments.table import Scalar, numeric_columns

SCHEMA = 1


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
    metrics: dict[str, Any] = {}
    for col in numeric_columns(rows):
        groups = groups_by_policy(spec, rows, col)
        metrics[col] = {
            "per_policy": {name: describe(vals).to_dict() for name, vals in groups.items()},
            "pairwise": [c.to_dict() for c in pairwise(groups, aligned=True)]
            if len(groups) > 1
            else [],
        }
    status: dict[str, dict[str, int]] = {}
    if any("status" in r for r in rows):
        for p in spec.policies:
            counts = Counter(str(r.get("status")) for r in rows if r["policy"] == p.name)
            status[p.name] = dict(sorted(counts.items()))
    walls = [float(r["run_wall_s"]) for r in records if r.get("run_wall_s") is not None]
    summary: dict[str, Any] = _finite(
        {
            "schema": SCHEMA,
            "scenario": {
                "name": getattr(spec.scenario, "name", None),
                "hash": spec.scenario_hash,
                "scale": spec.scale,
            },
            "policies": [
                {"number": p.number, "name": p.name, "label": p.label} for p in spec.policies
            ],
            "seeds": list(spec.seeds),
            "runs": len(rows),
            "status": status,
            "confidence": CONFIDENCE,
            "alpha": ALPHA,
            "tests": "two-sided Welch t-test and Mann–Whitney U per metric and pair of policies, "
            "Holm-corrected over the pairs of each metric (the verdicts use Welch); effect "
            "sizes Cohen's d (pooled sd) and rank-biserial r, both positive when policy a is "
            "larger. Every policy runs the same seeds (same worlds), so paired tests by seed "
            "(paired t, Wilcoxon signed-rank; Holm-corrected the same way) are reported too",
            "metrics": metrics,
            "compute": {
                "run_wall_s_total": round(sum(walls), 3),
                "run_wall_s_mean": round(sum(walls) / len(walls), 4) if walls else None,
            },
        }
    )
    return summary


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: write null instead of an invalid file."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
