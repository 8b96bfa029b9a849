"""Runs as a table: engine metrics flattened to columns, and runs.csv.

Nested metric dicts become underscore-joined columns (`distance.scout` → `distance_scout`,
`auction_open_s.scout_excavator.mean` → `auction_open_s_scout_excavator_mean`), so every
metric of `regolith run --json` is one column without the table knowing the engine's shape.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable, Mapping
from typing import Any

from experiments.journal import write_atomic
from experiments.spec import SweepSpec

NONDETERMINISTIC = frozenset({"wall_s"})
"""Metrics that measure the machine, not the mission: kept in the journal, not in runs.csv,
so the same sweep gives the same runs.csv on any executor."""

Scalar = float | int | str | bool | None


def flatten(metrics: Mapping[str, Any], prefix: str = "") -> dict[str, Scalar]:
    """Nested dicts → one level; lists become JSON text (they are not summarized)."""
    out: dict[str, Scalar] = {}
    for key, value in metrics.items():
        name = f"{prefix}_{key}" if prefix else str(key)
        if isinstance(value, Mapping):
            out.update(flatten(value, name))
        elif isinstance(value, (list, tuple)):
            out[name] = json.dumps(value, separators=(",", ":"))
        else:
            out[name] = value
    return out


def run_rows(spec: SweepSpec, records: Iterable[dict[str, Any]]) -> list[dict[str, Scalar]]:
    """One row per run, sorted by policy (research number) then seed."""
    rows = []
    for rec in records:
        policy = spec.policy(rec["policy"])
        metrics = {k: v for k, v in rec["metrics"].items() if k not in NONDETERMINISTIC}
        row: dict[str, Scalar] = {
            "policy": policy.name,
            "policy_number": policy.number,
            "seed": int(rec["seed"]),
            "scenario_hash": rec["scenario"],
        }
        for k, v in flatten(metrics).items():
            row.setdefault(k, v)
        rows.append(row)
    rows.sort(key=lambda r: (spec.policy(str(r["policy"])), r["seed"]))
    return rows


def columns(rows: Iterable[Mapping[str, Scalar]]) -> list[str]:
    """Column order: first appearance across rows, so the engine's own order is kept."""
    seen: dict[str, None] = {}
    for row in rows:
        for k in row:
            seen.setdefault(k, None)
    return list(seen)


def numeric_columns(rows: list[dict[str, Scalar]]) -> list[str]:
    """Columns that hold numbers (not bools) in at least one run: the ones worth summarizing."""
    skip = {"policy", "policy_number", "seed", "scenario", "scenario_hash"}
    out = []
    for col in columns(rows):
        if col in skip:
            continue
        vals = [r.get(col) for r in rows]
        if all(v is None or _is_number(v) for v in vals) and any(_is_number(v) for v in vals):
            out.append(col)
    return out


def _is_number(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def write_csv(rows: list[dict[str, Scalar]], path: Any) -> None:
    """runs.csv: floats in repr form (exact round trip), empty cell for a missing value."""
    buf = io.StringIO()
    cols = columns(rows)
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n", extrasaction="raise")
    w.writeheader()
    for row in rows:
        w.writerow({c: _cell(row.get(c)) for c in cols})
    write_atomic(path, buf.getvalue())


def _cell(v: Scalar) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(v) if isinstance(v, float) else str(v)
