"""What a reviewer reads: verdicts from the paired test, labelled and family-wide corrected
p-values, runs that did not complete counted and shown, figures at print resolution."""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from experiments.figures import (
    DPI,
    FigureSpec,
    PairedDiff,
    Panel,
    build_figure,
    build_paired_figure,
    figure_specs,
)
from experiments.outputs import write_outputs
from experiments.stats import holm
from tests.experiments.exp_fakes import fake_spec

SEEDS = 20


def record(
    policy: str, seed: int, makespan: float | None, status: str = "completed", **m: Any
) -> dict[str, Any]:
    rng = np.random.default_rng(seed * 7 + len(policy))
    return {
        "policy": policy,
        "seed": seed,
        "scenario": "x",
        "metrics": {
            "status": status,
            "makespan_s": makespan,
            "distance": {"scout": 2000 + rng.normal(0, 30), "hauler": 3000 + rng.normal(0, 90)},
            "counts": {"bids": 400 + seed},
            **m,
        },
    }


def paired_world(shift: float = 10.0) -> list[dict[str, Any]]:
    """The worlds differ a lot (±300 s), the policies little (coalition `shift` s faster on
    every seed, ±2 s): Welch sees the spread, the paired test sees the difference."""
    rng = np.random.default_rng(42)
    world = rng.normal(2000, 300, SEEDS)
    noise = rng.normal(0, 2, SEEDS)
    return [record("fcfs", s, float(world[s])) for s in range(SEEDS)] + [
        record("coalition", s, float(world[s] - shift + noise[s])) for s in range(SEEDS)
    ]


def outputs(
    tmp_path: Path, records: list[dict[str, Any]], policies: str = "1,2"
) -> tuple[dict[str, Any], str]:
    spec = fake_spec(policies, f"0-{SEEDS - 1}")
    write_outputs(spec, records, tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text())
    return summary, (tmp_path / "report.md").read_text()


def test_verdict_follows_the_paired_test_when_welch_sees_nothing(tmp_path: Path) -> None:
    summary, report = outputs(tmp_path, paired_world())
    assert summary["design"] == "paired" and summary["verdict_test"] == "paired_t"
    [c] = summary["metrics"]["makespan_s"]["pairwise"]
    assert c["welch_p_raw"] > 0.5 and not c["significant_welch"]  # the worlds' spread hides it
    assert c["paired_t_p_adj"] < 1e-4 and c["wilcoxon_p_adj"] < 0.05
    assert c["primary_test"] == "paired_t" and c["significant"]
    assert (c["a_lower"], c["b_lower"], c["n_pairs"]) == (0, SEEDS, SEEDS)
    assert c["paired_ci95"][0] == pytest.approx(10.0, abs=2) and c["paired_ci95"][0] > 0
    verdict = report.split("**Verdict.**")[1].split("##")[0]
    assert "Policy 2 (coalition) has the shortest mean makespan" in verdict
    assert "Paired by seed" in verdict and "significantly lower than Policy 1 (fcfs)" in verdict
    assert "Secondary, unpaired (Welch), there is no significant difference to P1" in verdict
    # the paired sections come before the unpaired ones, which say they are secondary
    assert report.index("## Paired tests by seed (the verdicts)") < report.index(
        "## Unpaired tests (secondary)"
    )


def test_paired_difference_figure_is_drawn_and_explained(tmp_path: Path) -> None:
    summary, report = outputs(tmp_path, paired_world())
    fig = next(f for f in summary["figures"] if f["name"] == "makespan_paired")
    for key in ("png", "svg"):
        assert (tmp_path / fig[key]).stat().st_size > 1000
    assert "P2 lower on 20 of 20 seeds" in fig["verdict"][0]
    assert "![Mission makespan: paired differences by seed](figures/makespan_paired.png)" in report


def test_no_significant_difference_is_said_when_paired_sees_nothing(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    world = rng.normal(2000, 300, SEEDS)
    records = [
        record(p, s, float(world[s] + rng.normal(0, 20)))
        for p in ("fcfs", "coalition")
        for s in range(SEEDS)
    ]
    summary, report = outputs(tmp_path, records)
    [c] = summary["metrics"]["makespan_s"]["pairwise"]
    assert not c["significant"]
    assert "there is no significant difference to Policy" in report


def test_p_values_are_labelled_and_adjusted_across_the_verdict_metrics(tmp_path: Path) -> None:
    summary, report = outputs(tmp_path, paired_world(shift=3.0), policies="1,2,3")
    corr = summary["correction"]
    family = corr["family_metrics"]
    assert family == ["makespan_s", "distance_scout", "distance_hauler"]
    assert corr["family_size"] == 3 * 3  # 3 pairs × 3 metrics with a verdict
    comps = [c for m in family for c in summary["metrics"][m]["pairwise"]]
    for test in ("welch", "mwu", "paired_t", "wilcoxon"):
        raw = [c[f"{test}_p_raw"] for c in comps]
        adj = [c[f"{test}_p_adj"] for c in comps]
        assert adj == [pytest.approx(a) if a is not None else None for a in holm(raw)]
        assert all(a is None or a >= r for r, a in zip(raw, adj, strict=True))
        assert any(a is not None and r is not None and a > r for r, a in zip(raw, adj, strict=True))
        assert not any(k in comps[0] for k in (f"{test}_p", f"{test}_p_holm"))  # unlabelled
    # the family is wider than one metric's pairs: makespan alone would adjust less
    mk = summary["metrics"]["makespan_s"]
    assert mk["correction"] == {"method": "holm", "family": "verdicts", "size": 9}
    own = holm([c["paired_t_p_raw"] for c in mk["pairwise"]])
    assert any(c["paired_t_p_adj"] > o for c, o in zip(mk["pairwise"], own, strict=True))
    # a metric without a verdict is adjusted over its own pairs only, and says so
    assert summary["metrics"]["counts_bids"]["correction"]["family"] == "metric"
    for header in (
        "paired t p (raw)",
        "paired t p (Holm adj.)",
        "Wilcoxon p (raw)",
        "Wilcoxon p (Holm adj.)",
        "Welch p (raw)",
        "Welch p (Holm adj.)",
        "Mann–Whitney p (raw)",
        "Mann–Whitney p (Holm adj.)",
    ):
        assert f"| {header} |" in report
    assert "Correction family: Holm over 9 comparisons" in report
    assert "`makespan_s`, `distance_scout`, `distance_hauler`" in report
    assert "p_adj" in report and "| p |" not in report


def test_timeouts_are_counted_shown_and_kept_out_of_the_means(tmp_path: Path) -> None:
    records = paired_world()
    for i, rec in enumerate(records):
        if rec["policy"] == "coalition" and rec["seed"] in (4, 11):
            records[i] = record("coalition", rec["seed"], None, status="timeout")
    records[0] = record("fcfs", 0, None, status="stalled")
    summary, report = outputs(tmp_path, records)
    assert summary["status"] == {
        "fcfs": {"completed": 19, "stalled": 1},
        "coalition": {"completed": 18, "timeout": 2},
    }
    assert summary["runs"] == 40 and summary["completed_runs"] == 37
    assert summary["not_completed"]["coalition"] == [
        {"seed": 4, "status": "timeout"},
        {"seed": 11, "status": "timeout"},
    ]
    # every metric's statistics are over completed runs, distance included
    for col in ("makespan_s", "distance_scout"):
        per = summary["metrics"][col]["per_policy"]
        assert (per["fcfs"]["n"], per["coalition"]["n"]) == (19, 18)
    assert summary["metrics"]["makespan_s"]["pairwise"][0]["n_pairs"] == 17
    assert "| policy | runs | completed | stalled | timeout | seeds not completed |" in report
    assert "| Policy 2 (coalition) | 20 | 18 | 0 | 2 | 4 (timeout), 11 (timeout) |" in report
    assert "| runs completed (the statistics' n) | 19 of 20 | 18 of 20 |" in report
    assert "3 of 40 runs did not complete" in report
    assert "Runs that did not complete (P1: 1 and P2: 2) are left out" in report


def test_all_completed_is_said(tmp_path: Path) -> None:
    _, report = outputs(tmp_path, paired_world())
    assert "All 40 runs completed." in report


def png_dpi_and_size(path: Path) -> tuple[float, tuple[int, int]]:
    """(dots per inch from the pHYs chunk, (width, height) in pixels)."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    at, dpi, size = 8, 0.0, (0, 0)
    while at < len(data):
        (length,), kind = struct.unpack(">I", data[at : at + 4]), data[at + 4 : at + 8]
        body = data[at + 8 : at + 8 + length]
        assert (
            zlib.crc32(kind + body)
            == struct.unpack(">I", data[at + 8 + length : at + 12 + length])[0]
        )
        if kind == b"IHDR":
            size = struct.unpack(">II", body[:8])
        elif kind == b"pHYs":
            x, _, unit = struct.unpack(">IIB", body)
            assert unit == 1  # metres
            dpi = x * 0.0254
        at += 12 + length
    return dpi, size


def test_figures_are_saved_at_print_resolution(tmp_path: Path) -> None:
    summary, _ = outputs(tmp_path, paired_world())
    assert {f["name"] for f in summary["figures"]} == {"makespan", "makespan_paired", "distance"}
    for f in summary["figures"]:
        dpi, (w, h) = png_dpi_and_size(tmp_path / f["png"])
        assert dpi == pytest.approx(300, abs=0.1)
        assert w >= 4 * 300 and h >= 3.5 * 300  # ≥ 4 × 3.5 inches at 300 dpi
        assert (tmp_path / f["svg"]).read_text().startswith("<?xml")


def _text_sizes(fig: Any) -> list[float]:
    fig.canvas.draw()
    sizes = []
    for ax in fig.axes:
        labels = [*ax.get_xticklabels(), *ax.get_yticklabels(), ax.yaxis.label, *ax.texts]
        sizes += [t.get_fontsize() for t in labels if t.get_text()]
    return sizes


def test_figure_text_is_readable_and_run_dots_visible() -> None:
    assert DPI == 300
    spec = FigureSpec("makespan", "Mission makespan", "makespan", "s", (Panel("m", "c"),))
    data = {"c": {"Policy 1 (fcfs)": [1.0, 2.0, 3.0], "Policy 2 (coalition)": [2.0, 3.0, 4.0]}}
    fig = build_figure(spec, data)
    sizes = _text_sizes(fig)
    assert sizes and min(sizes) >= 8
    dots: Any = fig.axes[0].collections[0]
    assert dots.get_sizes()[0] >= 12 and dots.get_linewidths()[0] > 0
    assert dots.get_facecolors()[0][3] >= 0.5 and dots.get_edgecolors()[0][3] >= 0.9
    paired = build_paired_figure(
        "t",
        "makespan",
        "s",
        "P2",
        [PairedDiff("Policy 1 (fcfs)", [1.0, 2.0, 4.0], (0.5, 4.0), "p_adj=0.01\nP2 lower 3/3")],
    )
    sizes = _text_sizes(paired)
    assert sizes and min(sizes) >= 8
    ax = paired.axes[0]
    assert any(
        np.asarray(line.get_ydata()).tolist() == [0.0, 0.0] for line in ax.get_lines()
    )  # zero line


def _outside(fig: Any) -> list[str]:
    """Every title, label, tick label, note and axes frame not wholly inside the figure (as
    saved: the same Agg drawing)."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    box = fig.bbox
    parts: list[Any] = [t for t in fig.texts if t.get_text()]
    if fig._suptitle is not None:
        parts.append(fig._suptitle)
    for ax in fig.axes:
        parts += [ax, ax.title, ax.yaxis.label, ax.xaxis.label, *ax.texts]
        parts += [*ax.get_xticklabels(), *ax.get_yticklabels()]
    out = []
    for part in parts:
        if hasattr(part, "get_text") and not part.get_text():
            continue
        ext = part.get_window_extent(renderer)
        inside = (
            ext.x0 >= box.x0 - 0.5
            and ext.x1 <= box.x1 + 0.5
            and ext.y0 >= box.y0 - 0.5
            and ext.y1 <= box.y1 + 0.5
        )
        if not inside:
            out.append(getattr(part, "get_text", lambda: "axes frame")())
    return out


@pytest.mark.parametrize("policies", [1, 2, 3, 6])
def test_every_figure_fits_its_title_and_frames(policies: int) -> None:
    """A long title (the makespan ratio's) or many policies never push text or a frame out of
    the saved image."""
    cols = ["makespan_s", "makespan_ratio", "distance_scouts", "distance_haulers"]
    labels = [f"Policy {i} (name-{i})" for i in range(1, policies + 1)]
    for spec in figure_specs(cols):
        data = {p.column: {k: [1.0, 1.2, 1.5] for k in labels} for p in spec.panels}
        assert _outside(build_figure(spec, data)) == [], spec.name
    comps = [PairedDiff(k, [0.0, 0.0, 0.0], (0.0, 0.0), "p_adj=n/a\nequal 3/3") for k in labels]
    title = "Makespan / per-run lower bound: difference from Policy 1 (fcfs)\non the same seed"
    paired = build_paired_figure(title, "makespan / per-run lower bound", "×", "P1", comps)
    assert _outside(paired) == []


def test_an_exact_tie_is_said_to_be_one(tmp_path: Path) -> None:
    """Two policies equal on every seed (the same makespans and distances): no signed zero,
    no "lower on 0 of 20 seeds", but an exact tie."""
    rng = np.random.default_rng(8)
    world = rng.normal(2000, 300, SEEDS)
    records = [
        record(p, s, float(world[s]), distance={"scout": 2000.0 + s, "hauler": 3000.0 - s})
        for p in ("fcfs", "coalition")
        for s in range(SEEDS)
    ]
    summary, report = outputs(tmp_path, records)
    verdicts = " ".join(v for f in summary["figures"] for v in f.get("verdict", []))
    for text in (report, verdicts):
        assert "-0.0" not in text and "−0.0" not in text, text
        assert "lower on 0 of" not in text, text
    assert f"equal on {SEEDS} of {SEEDS} seeds" in report and "exact tie" in report
