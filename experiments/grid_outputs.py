"""What a grid sweep writes next to its journal: runs.csv and bounds.csv with one column per
grid parameter, summary.json with one summary per point, the winner maps or the line plot,
and report.md.

Each point is analysed exactly as a sweep of its own scenario would be (`build_summary` over
that point's runs), so a point's statistics, tests and corrections are those of a plain sweep;
the winner at a point is the policy with the lowest mean over completed runs, and its win is
significant when that point's verdict test against the runner-up (paired t, Holm-adjusted
over the point's verdict family) says so. Nothing is corrected across points.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from experiments.bound import BoundFn, bound_columns
from experiments.figures import figure_specs, save
from experiments.grid import Grid, GridPoint, fmt_value
from experiments.grid_figures import Cell, MapPanel, Series, build_line_plot, build_winner_map
from experiments.journal import write_atomic
from experiments.report import fmt_num, fmt_pv
from experiments.spec import SweepSpec
from experiments.summary import SCHEMA, build_summary, completed_rows
from experiments.table import Scalar, numeric_columns, run_rows, write_csv

FIG_DIR = "figures"

WINNER_METRICS = (("makespan", "makespan", "s"), ("excavator_distance", "excavator distance", "m"))
"""(key, what the figure calls it, unit): the metrics whose winner a map shows."""


def winner_columns(rows: list[dict[str, Scalar]]) -> dict[str, str]:
    """The runs.csv columns of the makespan and of the excavators' distance, where present."""
    out: dict[str, str] = {}
    for fs in figure_specs(numeric_columns(completed_rows(rows))):
        if fs.name == "makespan":
            out["makespan"] = fs.panels[0].column
        if fs.name == "distance":
            for panel in fs.panels:
                if panel.noun == "excavator":
                    out["excavator_distance"] = panel.column
    return out


def point_winner(spec: SweepSpec, summary: dict[str, Any], column: str) -> dict[str, Any] | None:
    """The policy with the lowest mean at a point, and its verdict test against the runner-up."""
    metric = summary["metrics"].get(column)
    if metric is None:
        return None
    per = metric["per_policy"]
    order = {p.name: i for i, p in enumerate(spec.policies)}
    have = sorted(
        (p for p in spec.policies if per[p.name]["mean"] is not None),
        key=lambda p: (per[p.name]["mean"], order[p.name]),
    )
    if not have:
        return None
    best = have[0]
    out: dict[str, Any] = {
        "policy": best.name,
        "label": best.label,
        "mean": per[best.name]["mean"],
        "ci95": per[best.name]["ci95"],
        "runner_up": None,
        "margin": None,
        "test": None,
        "p_adj": None,
        "significant": False,
    }
    if len(have) > 1:
        ru = have[1]
        c = next(c for c in metric["pairwise"] if {c["a"], c["b"]} == {best.name, ru.name})
        test = c["primary_test"]
        out.update(
            runner_up=ru.name,
            margin=per[ru.name]["mean"] - per[best.name]["mean"],
            test=test,
            p_adj=c[f"{test}_p_adj"],
            significant=bool(c["significant"]),
        )
    return out


def write_grid_outputs(
    spec: SweepSpec,
    records: list[dict[str, Any]],
    out_dir: Path,
    bound_fn: BoundFn | None = None,
) -> list[Path]:
    """Regenerate every derived file of a grid sweep from the journal's records (idempotent)."""
    grid = spec.grid
    assert grid is not None
    out_dir = Path(out_dir)
    by_point: dict[str, list[dict[str, Any]]] = {pt.hash: [] for pt in grid.points}
    for rec in records:
        by_point[str(rec["scenario"])].append(rec)
    all_rows: list[dict[str, Scalar]] = []
    all_bounds: list[dict[str, Any]] = []
    points: list[dict[str, Any]] = []
    analysed: list[tuple[GridPoint, dict[str, Any]]] = []
    for pt in grid.points:
        pspec = replace(spec, scenario=pt.scenario, grid=None)
        rows = run_rows(pspec, by_point[pt.hash])
        if bound_fn is not None:
            bounds = bound_columns(rows, pt.scenario, bound_fn)
            all_bounds += [{**_grid_cols(pt), **b} for b in bounds]
        summary = build_summary(pspec, rows, by_point[pt.hash])
        all_rows += [_with_point(row, pt) for row in rows]
        analysed.append((pt, summary))
    wcols = winner_columns(all_rows)
    for pt, summary in analysed:
        pspec = replace(spec, scenario=pt.scenario, grid=None)
        points.append(
            {
                "index": pt.index,
                "values": pt.as_dict(),
                "scenario_hash": pt.hash,
                "winners": {k: point_winner(pspec, summary, col) for k, col in wcols.items()},
                "summary": summary,
            }
        )
    files = [out_dir / "runs.csv"]
    write_csv(all_rows, files[0])
    if bound_fn is not None:
        files.append(out_dir / "bounds.csv")
        write_csv(all_bounds, files[-1])
    figures = grid_figures(spec, grid, points, wcols, out_dir / FIG_DIR)
    for f in figures:
        files += [out_dir / f["png"], out_dir / f["svg"]]
    total = sum(p["summary"]["runs"] for p in points)
    summary_all: dict[str, Any] = {
        "schema": SCHEMA,
        "kind": "grid",
        "scenario": {
            "name": getattr(spec.scenario, "name", None),
            "hash": spec.scenario_hash,
            "scale": spec.scale,
            "note": "the base scenario; each point overrides the grid parameters",
        },
        "grid": {
            "parameters": grid.paths,
            "values": {p.path: list(p.values) for p in grid.params},
            "points": len(grid.points),
        },
        "policies": [{"number": p.number, "name": p.name, "label": p.label} for p in spec.policies],
        "seeds": list(spec.seeds),
        "runs": total,
        "completed_runs": sum(p["summary"]["completed_runs"] for p in points),
        "winner_metrics": wcols,
        "winner_rule": "lowest mean over completed runs; significant when the point's verdict "
        "test (paired t on per-seed differences, Holm-adjusted over the point's verdict "
        "family) against the runner-up has p_adj < alpha; not corrected across points",
        "points": points,
        "figures": figures,
    }
    write_atomic(
        out_dir / "summary.json", json.dumps(summary_all, indent=2, allow_nan=False) + "\n"
    )
    write_atomic(out_dir / "report.md", render_grid_report(spec, grid, summary_all))
    files += [out_dir / "summary.json", out_dir / "report.md"]
    return files


def _grid_cols(pt: GridPoint) -> dict[str, Any]:
    return {path: _scalar(v) for path, v in pt.values}


def _scalar(v: Any) -> Scalar:
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    return fmt_value(v)


def _with_point(row: dict[str, Scalar], pt: GridPoint) -> dict[str, Scalar]:
    """The run's row with the grid columns after its identity columns."""
    head = ("policy", "policy_number", "seed", "scenario_hash")
    out = {k: row[k] for k in head if k in row}
    out.update(_grid_cols(pt))
    out.update({k: v for k, v in row.items() if k not in out})
    return out


def grid_figures(
    spec: SweepSpec,
    grid: Grid,
    points: list[dict[str, Any]],
    wcols: dict[str, str],
    fig_dir: Path,
) -> list[dict[str, Any]]:
    """Winner maps for every pair of parameters; with one parameter, a line plot."""
    out: list[dict[str, Any]] = []
    labels = [p.label for p in spec.policies]
    index = {p.name: i for i, p in enumerate(spec.policies)}
    short = {p.name: p.short for p in spec.policies}
    params = grid.params
    metrics = [m for m in WINNER_METRICS if m[0] in wcols]
    if len(params) == 1:
        prm = params[0]
        for key, quantity, unit in metrics:
            column = wcols[key]
            series = []
            for p in spec.policies:
                d = [
                    pt["summary"]["metrics"].get(column, {}).get("per_policy", {}).get(p.name, {})
                    for pt in points
                ]
                ci = [x.get("ci95") or [None, None] for x in d]
                series.append(
                    Series(
                        p.label,
                        index[p.name],
                        [x.get("mean") for x in d],
                        [c[0] for c in ci],
                        [c[1] for c in ci],
                    )
                )
            name = f"grid_{key}"
            fig = build_line_plot(
                f"Mean {quantity} per policy vs {prm.path} (95% CI)",
                prm.path,
                list(prm.values),
                f"{quantity} ({unit})",
                series,
            )
            save(fig, name, fig_dir)
            out.append(_entry(name, f"Mean {quantity} vs {prm.path}", [column]))
        return out
    # points come in product order: the i-th holds these value indices
    at = dict(
        zip(
            itertools.product(*(range(len(p.values)) for p in params)),
            points,
            strict=True,
        )
    )
    for a, b in itertools.combinations(range(len(params)), 2):
        others = [i for i in range(len(params)) if i not in (a, b)]
        for key, quantity, _unit in metrics:
            panels = []
            for combo in itertools.product(*(range(len(params[i].values)) for i in others)):
                cells: dict[tuple[int, int], Cell] = {}
                for yi, xi in itertools.product(
                    range(len(params[a].values)), range(len(params[b].values))
                ):
                    pos = dict(zip(others, combo, strict=True)) | {a: yi, b: xi}
                    w = at[tuple(pos[i] for i in range(len(params)))]["winners"].get(key)
                    cells[(yi, xi)] = (
                        Cell(None)
                        if w is None
                        else Cell(
                            index[w["policy"]],
                            short[w["policy"]],
                            short.get(w["runner_up"] or "", ""),
                            w["p_adj"],
                            w["significant"],
                        )
                    )
                title = ", ".join(
                    f"{params[i].path}={fmt_value(params[i].values[j])}"
                    for i, j in zip(others, combo, strict=True)
                )
                panels.append(MapPanel(title, cells))
            name = f"grid_winner_{key}__{_stem(params[a].path)}__{_stem(params[b].path)}"
            fig = build_winner_map(
                f"Lowest mean {quantity}: which policy wins where",
                params[b].path,
                [fmt_value(v) for v in params[b].values],
                params[a].path,
                [fmt_value(v) for v in params[a].values],
                panels,
                labels,
                "paired t, Holm-adj. p",
            )
            save(fig, name, fig_dir)
            out.append(
                _entry(
                    name,
                    f"Winner by mean {quantity}: {params[a].path} × {params[b].path}",
                    [wcols[key]],
                )
            )
    return out


def _stem(path: str) -> str:
    return path.replace(".", "-")


def _entry(name: str, title: str, columns: list[str]) -> dict[str, Any]:
    return {
        "name": name,
        "title": title,
        "png": f"{FIG_DIR}/{name}.png",
        "svg": f"{FIG_DIR}/{name}.svg",
        "columns": columns,
    }


def render_grid_report(spec: SweepSpec, grid: Grid, summary: dict[str, Any]) -> str:
    """report.md of a grid sweep: the design, the figures, the winners and means per point."""
    params = " × ".join(
        f"`{p.path}` ({', '.join(fmt_value(v) for v in p.values)})" for p in grid.params
    )
    lines = [
        f"# Grid sweep: {summary['scenario']['name']}",
        "",
        f"Policies {', '.join(p.label for p in spec.policies)}; seeds "
        f"{_seed_text(spec.seeds)}; grid {params}: {len(grid.points)} points, "
        f"{summary['runs']} runs ({summary['completed_runs']} completed).",
        "",
        "Every policy plays the same seeds at every point. The winner at a point has the "
        "lowest mean over completed runs; its win is significant when that point's paired "
        "t-test against the runner-up (Holm-adjusted over the point's verdict family, as in "
        "a plain sweep's report) gives p_adj < 0.05. Nothing is corrected across points, so "
        "with many points expect some pale cells to flip on another set of seeds.",
        "",
    ]
    for f in summary["figures"]:
        lines += [f"![{f['title']}]({f['png']})", ""]
    wm = summary["winner_metrics"]
    head = ["point"]
    for key, quantity, unit in WINNER_METRICS:
        if key in wm:
            head += [f"{quantity} winner", f"mean ({unit})", "runner-up", "p_adj", "significant"]
    lines += ["## Winners per point", "", "| " + " | ".join(head) + " |"]
    lines.append("|" + " --- |" * len(head))
    for pt in summary["points"]:
        cells = [", ".join(f"{k}={fmt_value(v)}" for k, v in pt["values"].items())]
        for key, _q, _u in WINNER_METRICS:
            if key not in wm:
                continue
            w = pt["winners"].get(key)
            if w is None:
                cells += ["–"] * 5
                continue
            cells += [
                w["label"],
                fmt_num(w["mean"]),
                spec.policy(w["runner_up"]).label if w["runner_up"] else "–",
                fmt_pv(w["p_adj"]),
                "yes" if w["significant"] else "no",
            ]
        lines.append("| " + " | ".join(cells) + " |")
    if "makespan" in wm:
        col = wm["makespan"]
        lines += ["", "## Mean makespan (s) ± 95% CI half-width", ""]
        lines.append("| point | " + " | ".join(p.label for p in spec.policies) + " |")
        lines.append("|" + " --- |" * (1 + len(spec.policies)))
        for pt in summary["points"]:
            per = pt["summary"]["metrics"].get(col, {}).get("per_policy", {})
            row = [", ".join(f"{k}={fmt_value(v)}" for k, v in pt["values"].items())]
            for p in spec.policies:
                d = per.get(p.name, {})
                m, ci = d.get("mean"), d.get("ci95") or [None, None]
                hw = None if m is None or ci[1] is None else ci[1] - m
                row.append(f"{fmt_num(m)} ± {fmt_num(hw)}" if hw is not None else fmt_num(m))
            lines.append("| " + " | ".join(row) + " |")
    missing = [
        pt for pt in summary["points"] if pt["summary"]["completed_runs"] < pt["summary"]["runs"]
    ]
    if missing:
        lines += ["", "## Runs that did not complete", ""]
        for pt in missing:
            s = pt["summary"]
            label = ", ".join(f"{k}={fmt_value(v)}" for k, v in pt["values"].items())
            lines.append(
                f"- {label}: {s['runs'] - s['completed_runs']} of {s['runs']} runs left out "
                f"of every statistic ({json.dumps(s['not_completed'])})"
            )
    lines += [
        "",
        "Per point, summary.json's `points[i].summary` holds the full statistics of a plain "
        "sweep (every metric, every pair, raw and adjusted p-values).",
        "",
    ]
    return "\n".join(lines)


def _seed_text(seeds: tuple[int, ...]) -> str:
    if len(seeds) > 2 and list(seeds) == list(range(seeds[0], seeds[-1] + 1)):
        return f"{seeds[0]}–{seeds[-1]}"
    return ", ".join(str(s) for s in seeds)
