"""The comparison figures: per-run distributions per policy, with the mean and its 95% CI;
and the paired figure: per-seed differences from the best policy.

Built on `matplotlib.figure.Figure` (Agg canvas, no pyplot state), so a service thread can
draw while another does the same. Output is byte-stable: no dates in SVG or PNG metadata.
Print resolution: PNG at 300 dpi (pHYs says so), text at least 8 pt at the saved size.
"""

from __future__ import annotations

import re
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure

from experiments.stats import describe

mpl.rcParams["svg.hashsalt"] = "regolith"  # stable element ids in SVG output

ROBOT_TYPES = ("scout", "excavator", "hauler")
AUCTION_KINDS = ("scout_excavator", "excavator_hauler")
COLORS = ("#4C72B0", "#DD8452", "#55A868", "#C44E52", "#8172B3", "#937860", "#DA8BC3")
DPI = 300
"""PNG resolution: print quality. The figure sizes are in inches, so fonts keep their size."""
TICK_PT, LABEL_PT, TITLE_PT = 9.0, 10.0, 11.0
"""Text sizes in points at the saved size (a reviewer's minimum is 8 pt)."""
DOT = {"s": 16.0, "face_alpha": 0.5, "edge_alpha": 0.9, "linewidths": 0.5}
"""One run: a half-transparent disc with an opaque edge of the same colour, so single runs
stay visible and overlapping ones still read as density."""


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
                "Makespan / per-run lower bound (1 = optimal for the run's discoveries)",
                "makespan / per-run lower bound",
                "×",
                (Panel("makespan / per-run lower bound", "makespan_ratio"),),
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


def build_figure(
    spec: FigureSpec, data: Mapping[str, Mapping[str, Sequence[float | None]]]
) -> Figure:
    """Box + strip per policy in each panel, the mean with its 95% CI on top.

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
    _suptitle(fig, spec.title)
    return fig


def draw(
    spec: FigureSpec,
    data: Mapping[str, Mapping[str, Sequence[float | None]]],
    out_dir: Path,
) -> list[Path]:
    """`build_figure`, saved as PNG (300 dpi) and SVG."""
    return save(build_figure(spec, data), spec.name, out_dir)


def save(fig: Figure, name: str, out_dir: Path) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    png, svg = out_dir / f"{name}.png", out_dir / f"{name}.svg"
    fig.savefig(png, dpi=DPI, metadata={"Software": None})
    fig.savefig(svg, metadata={"Date": None, "Creator": None})
    return [png, svg]


@dataclass(frozen=True)
class PairedDiff:
    """One comparison of the paired figure: per-seed values of `label` minus the reference."""

    label: str
    diffs: Sequence[float]
    ci95: tuple[float | None, float | None]
    note: str  # printed above the strip: the adjusted p-value, seeds lower
    color: int = 0  # the policy's colour index, as in the other figures


def build_paired_figure(
    title: str, quantity: str, unit: str, reference: str, comps: Sequence[PairedDiff]
) -> Figure:
    """Per-seed differences (policy − reference), one strip per policy, a zero line, the mean
    difference with its 95% CI (the paired t interval) and the test result above each strip.

    Above zero: the policy is higher than the reference on that seed.
    """
    k = max(1, len(comps))
    fig = Figure(figsize=(max(4.6, 1.0 + 1.25 * k), 4.0), layout="constrained")
    ax = fig.subplots()
    pos = np.arange(1, k + 1)
    ax.axhline(0.0, color="#333333", linewidth=1.0, zorder=1)
    jitter = np.random.default_rng(0)
    for i, c in enumerate(comps):
        v = np.asarray(c.diffs, dtype=float)
        color = COLORS[c.color % len(COLORS)]
        xs = pos[i] + jitter.uniform(-0.18, 0.18, v.size)
        _dots(ax, xs, v, color)
        if v.size:
            mean = float(v.mean())
            lo, hi = c.ci95
            err = None if lo is None or hi is None else [[mean - lo], [hi - mean]]
            ax.errorbar(
                pos[i] + 0.32, mean, yerr=err, fmt="D", color="black", ms=5, capsize=4, zorder=3
            )
    ax.set_xticks(pos, [_wrap(c.label) for c in comps] if comps else [""])
    ax.set_xlim(0.4, k + 0.75)
    lo_y, hi_y = ax.get_ylim()
    span = hi_y - lo_y or 1.0
    ax.set_ylim(lo_y, hi_y + 0.22 * span)  # headroom for the notes
    for i, c in enumerate(comps):
        ax.text(
            pos[i] + 0.07,
            hi_y + 0.04 * span,
            c.note,
            ha="center",
            va="bottom",
            fontsize=TICK_PT - 1 if len(c.note) > 24 else TICK_PT,
        )
    ax.set_ylabel(f"{quantity}: policy − {reference} ({unit})", fontsize=LABEL_PT)
    ax.tick_params(labelsize=TICK_PT)
    ax.grid(axis="y", alpha=0.3)
    _suptitle(fig, title)
    return fig


def _suptitle(fig: Figure, title: str) -> None:
    """The title, wrapped to the figure's width: constrained layout makes room above the axes
    for a tall title but never narrows a wide one, which was cut at both sides (and took the
    right frame's place: "Makespan / per-run lower bound (1 = optimal …)" on a one-panel
    figure). A character is taken as 0.6 em, wider than the average of the default font."""
    per_line = max(20, int(fig.get_figwidth() * 72 / (0.6 * TITLE_PT)) - 2)
    lines = [textwrap.fill(line, per_line) for line in title.splitlines()]
    fig.suptitle("\n".join(lines), fontsize=TITLE_PT)


def _dots(ax: Axes, xs: np.ndarray, ys: np.ndarray, color: str) -> None:
    ax.scatter(
        xs,
        ys,
        s=DOT["s"],
        facecolors=[to_rgba(color, DOT["face_alpha"])],
        edgecolors=[to_rgba(color, DOT["edge_alpha"])],
        linewidths=DOT["linewidths"],
        zorder=2,
    )


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
        _dots(ax, xs, v, color)
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
    ax.set_ylabel(ylabel, fontsize=LABEL_PT)
    ax.tick_params(labelsize=TICK_PT)
    if title:
        ax.set_title(title, fontsize=LABEL_PT)
    ax.grid(axis="y", alpha=0.3)


def _wrap(label: str) -> str:
    """'Policy 3 (nearest)' → two lines, so many policies fit under a narrow panel."""
    return label.replace(" (", "\n(")
