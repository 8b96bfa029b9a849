"""The comparison figures: per-run distributions per policy, with the mean and its 95% CI.

Built on `matplotlib.figure.Figure` (Agg canvas, no pyplot state), so a service thread can
draw while another does the same. Output is byte-stable: no dates in SVG or PNG metadata.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from experiments.stats import describe

mpl.rcParams["svg.hashsalt"] = "regolith"  # stable element ids in SVG output

ROBOT_TYPES = ("scout", "excavator", "hauler")
AUCTION_KINDS = ("scout_excavator", "excavator_hauler")
COLORS = ("#4C72B0", "#DD8452", "#55A868", "#C44E52", "#8172B3", "#937860", "#DA8BC3")


@dataclass(frozen=True)
class Panel:
    title: str
    column: str
    noun: str = ""  # qualifies the quantity in a verdict: "scout" distance


@dataclass(frozen=True)
class FigureSpec:
    """One figure: a name (file stem), what it shows, and one panel per metric column."""

    name: str
    title: str
    quantity: str  # as the verdict names it: "makespan", "scout distance", …
    unit: str
    panels: tuple[Panel, ...]


def _first(cols: Sequence[str], pattern: str) -> str | None:
    rx = re.compile(pattern)
    return next((c for c in cols if rx.search(c)), None)


def figure_specs(cols: Sequence[str]) -> list[FigureSpec]:
    """Find the research's three figures among the numeric columns of runs.csv."""
    specs: list[FigureSpec] = []
    mk = _first(cols, r"^makespan") or _first(cols, r"makespan")
    if mk:
        specs.append(
            FigureSpec("makespan", "Mission makespan", "makespan", "s", (Panel("makespan", mk),))
        )
    if "makespan_ratio" in cols:
        specs.append(
            FigureSpec(
                "makespan_ratio",
                "Makespan / lower bound (1 = provably optimal)",
                "makespan / lower bound",
                "×",
                (Panel("makespan / lower bound", "makespan_ratio"),),
            )
        )
    dist = [
        (t, c) for t in ROBOT_TYPES if (c := _first(cols, rf"^distance\w*_{t}s?(_total|_sum)?$"))
    ]
    if dist:
        panels = tuple(Panel(f"{t}s", c, t) for t, c in dist)
        specs.append(
            FigureSpec("distance", "Distance travelled per robot type", "distance", "m", panels)
        )
    auc = [(k, c) for k in AUCTION_KINDS if (c := _first(cols, rf"^auction_open\w*{k}\w*_mean$"))]
    if auc:
        panels = tuple(Panel(k.replace("_", "→"), c, k.replace("_", "→")) for k, c in auc)
        specs.append(
            FigureSpec(
                "auction_open", "Auction open time (per-run mean)", "auction open time", "s", panels
            )
        )
    return specs


def draw(
    spec: FigureSpec,
    data: Mapping[str, Mapping[str, Sequence[float | None]]],
    out_dir: Path,
) -> list[Path]:
    """Box + strip per policy in each panel, the mean with its 95% CI on top; PNG and SVG.

    `data[column][policy_label]` holds one value per run.
    """
    n = len(spec.panels)
    k = max((len(data[p.column]) for p in spec.panels), default=0)  # policies per panel
    panel_w = max(3.4, 0.8 + 0.85 * k)  # room for each policy's two-line label
    fig = Figure(figsize=(max(4.2, panel_w * n), 3.8), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)[0]
    for ax, panel in zip(axes, spec.panels, strict=True):
        ylabel = f"{spec.quantity} ({spec.unit})"
        _panel(ax, data[panel.column], panel.title if n > 1 else "", ylabel)
    fig.suptitle(spec.title)
    out_dir.mkdir(parents=True, exist_ok=True)
    png, svg = out_dir / f"{spec.name}.png", out_dir / f"{spec.name}.svg"
    fig.savefig(png, dpi=90, metadata={"Software": None})
    fig.savefig(svg, metadata={"Date": None, "Creator": None})
    return [png, svg]


def _panel(ax: Axes, groups: Mapping[str, Sequence[float | None]], title: str, ylabel: str) -> None:
    labels = list(groups)
    values = [np.asarray([v for v in groups[k] if v is not None], dtype=float) for k in labels]
    pos = np.arange(1, len(labels) + 1)
    keep = [i for i, v in enumerate(values) if v.size]
    if keep:
        ax.boxplot(
            [values[i] for i in keep],
            positions=pos[keep],
            widths=0.5,
            showfliers=False,
            medianprops={"color": "#333333"},
            boxprops={"color": "#777777"},
            whiskerprops={"color": "#777777"},
            capprops={"color": "#777777"},
        )
    jitter = np.random.default_rng(0)  # fixed: the same data always draws the same picture
    for i, v in enumerate(values):
        color = COLORS[i % len(COLORS)]
        xs = pos[i] + jitter.uniform(-0.16, 0.16, v.size)
        ax.scatter(xs, v, s=9, alpha=0.45, color=color, linewidths=0, zorder=2)
        d = describe(list(v))
        if d.mean is not None:
            err = None
            if d.ci_low is not None and d.ci_high is not None:
                err = [[d.mean - d.ci_low], [d.ci_high - d.mean]]
            ax.errorbar(
                pos[i] + 0.3, d.mean, yerr=err, fmt="D", color="black", ms=4, capsize=3, zorder=3
            )
    ax.set_xticks(pos, [_wrap(lb) for lb in labels])
    ax.set_xlim(0.4, len(labels) + 0.7)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title, fontsize=10)
    ax.grid(axis="y", alpha=0.3)


def _wrap(label: str) -> str:
    """'Policy 3 (nearest)' → two lines, so many policies fit under a narrow panel."""
    return label.replace(" (", "\n(")
