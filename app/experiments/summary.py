"""summary.json: per policy and metric the descriptive statistics, per metric the pairwise tests.

Everything here is a pure function of the runs, so the same journal gives the same summary
(apart from the `compute` section, which records how long the runs took on their machines).
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

from app.experiments.spec import SweepSpec
from app.experiments.stats import ALPHA, CONFIDENCE, describe, pairwise
from app.experiments.table import Scalar, numeric_columns

SCHEMA = 1


def groups_by_policy(
    spec: SweepSpec, rows: list[dict[str, Scalar]], column: str
) -> dict[str, list[float | None]]:
    """One value per run of each policy, in the spec's policy order."""
    out: dict[str, list[float | None]] = {p.name: [] for p in spec.policies}
    for row in rows:
        v = row.get(column)
        out[str(row["policy"])].append(None if v is None else float(v))  # type: ignore[arg-type]
    return out


def build_summary(
    spec: SweepSpec, rows: list[dict[str, Scalar]], records: list[dict[str, Any]]
) -> dict[str, Any]:
    metrics: dict[str, Any] = {}
    for col in numeric_columns(rows):
        groups = groups_by_policy(spec, rows, col)
        metrics[col] = {
            "per_policy": {name: describe(vals).to_dict() for name, vals in groups.items()},
            "pairwise": [c.to_dict() for c in pairwise(groups)] if len(groups) > 1 else [],
        }
    status: dict[str, dict[str, int]] = {}
    if any("status" in r for r in rows):
        for p in spec.policies:
            counts = Counter(str(r.get("status")) for r in rows if r["policy"] == p.name)
            status[p.name] = dict(sorted(counts.items()))
    walls = [float(r["run_wall_s"]) for r in records if r.get("run_wall_s") is not None]
    return _finite(
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
            "Holm-corrected over the pairs of each metric; effect sizes Cohen's d (pooled sd) "
            "and rank-biserial r, both positive when policy a is larger",
            "metrics": metrics,
            "compute": {
                "run_wall_s_total": round(sum(walls), 3),
                "run_wall_s_mean": round(sum(walls) / len(walls), 4) if walls else None,
            },
        }
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
