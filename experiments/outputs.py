"""Everything a finished sweep writes next to its journal: runs.csv, summary, figures, report."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from experiments.bound import BoundFn, bound_columns
from experiments.figures import draw, figure_specs
from experiments.journal import write_atomic
from experiments.report import render_report, verdict
from experiments.spec import SweepSpec
from experiments.summary import build_summary, groups_by_policy
from experiments.table import numeric_columns, run_rows, write_csv

FIG_DIR = "figures"


def write_outputs(
    spec: SweepSpec,
    records: list[dict[str, Any]],
    out_dir: Path,
    bound_fn: BoundFn | None = None,
) -> list[Path]:
    """Regenerate every derived file from the journal's records (idempotent).

    With `bound_fn` (the engine's world → makespan lower bound) each run also gets
    lower_bound_s and makespan_ratio, and bounds.csv lists every term per seed.
    """
    out_dir = Path(out_dir)
    rows = run_rows(spec, records)
    files = [out_dir / "runs.csv"]
    if bound_fn is not None:
        files.append(out_dir / "bounds.csv")
        write_csv(bound_columns(rows, spec.scenario, bound_fn), files[-1])
    write_csv(rows, files[0])
    summary = build_summary(spec, rows, records)
    labels = {p.name: p.label for p in spec.policies}
    figures = []
    for fs in figure_specs(numeric_columns(rows)):
        data = {
            panel.column: {
                labels[name]: vals
                for name, vals in groups_by_policy(spec, rows, panel.column).items()
            }
            for panel in fs.panels
        }
        paths = draw(fs, data, out_dir / FIG_DIR)
        files.extend(paths)
        figures.append(
            {
                "name": fs.name,
                "title": fs.title,
                "png": f"{FIG_DIR}/{fs.name}.png",
                "svg": f"{FIG_DIR}/{fs.name}.svg",
                "columns": [p.column for p in fs.panels],
                "verdict": verdict(fs, summary, spec),
            }
        )
    summary["figures"] = figures
    write_atomic(out_dir / "summary.json", json.dumps(summary, indent=2, allow_nan=False) + "\n")
    write_atomic(out_dir / "report.md", render_report(spec, summary))
    files += [out_dir / "summary.json", out_dir / "report.md"]
    return files
