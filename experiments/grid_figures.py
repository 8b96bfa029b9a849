"""The figures of a grid sweep: which policy wins where, and a metric along one parameter.

A winner map puts one grid parameter on each axis; each cell is coloured by the policy with
the lowest mean at that point (its colour in every other figure), solid where its win over
the runner-up is significant and pale where it is not, and says so in words: the winner's
short label, the runner-up and the adjusted p-value. With more than two parameters there is
one panel per combination of the others. Same conventions as `experiments.figures`: Agg
`Figure`, PNG at 300 dpi and SVG, text at least 8 pt.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from experiments.figures import COLORS, LABEL_PT, TICK_PT, TITLE_PT
from experiments.stats import ALPHA

PALE = 0.3
"""How much of a non-significant winner's colour shows (the rest is white)."""
EMPTY = "#dddddd"


@dataclass(frozen=True)
class Cell:
    """One point of a winner map."""

    winner: int | None  # index into the policies (its colour), None: no completed run
    short: str = ""
    runner_up: str = ""
    p_adj: float | None = None
    significant: bool = False


@dataclass(frozen=True)
class MapPanel:
    title: str  # the other parameters' values, "" with a two-parameter grid
    cells: Mapping[tuple[int, int], Cell]  # (y index, x index) → cell


def fmt_p_short(p: float | None) -> str:
    if p is None:
        return "p n/a"
    return "p<0.001" if p < 0.001 else f"p={p:.3f}" if p < 0.1 else f"p={p:.2f}"


def cell_text(c: Cell) -> str:
    if c.winner is None:
        return "no runs"
    if not c.runner_up:
        return c.short
    mark = "" if c.significant else " n.s."
    return f"{c.short}\nvs {c.runner_up}\n{fmt_p_short(c.p_adj)}{mark}"


def build_winner_map(
    title: str,
    x_name: str,
    x_values: Sequence[str],
    y_name: str,
    y_values: Sequence[str],
    panels: Sequence[MapPanel],
    policies: Sequence[str],
    test_note: str,
) -> Figure:
    """One heat map per panel: cell colour = winning policy, solid = significant win."""
    n = max(1, len(panels))
    ncols = min(3, n)
    nrows = -(-n // ncols)
    nx, ny = max(1, len(x_values)), max(1, len(y_values))
    cell_w, cell_h = 0.95, 0.72
    pw, ph = max(2.6, 1.1 + cell_w * nx), max(2.0, 0.8 + cell_h * ny)
    fig = Figure(figsize=(max(5.2, pw * ncols + 0.4), ph * nrows + 1.5), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for i, ax in enumerate(axes.flat):
        if i >= len(panels):
            ax.set_visible(False)
            continue
        panel = panels[i]
        img = np.ones((ny, nx, 3))
        for (yi, xi), c in panel.cells.items():
            img[yi, xi] = _cell_rgb(c)
        ax.imshow(img, origin="lower", aspect="auto", interpolation="nearest")
        for (yi, xi), c in panel.cells.items():
            dark = c.winner is not None and c.significant
            ax.text(
                xi,
                yi,
                cell_text(c),
                ha="center",
                va="center",
                fontsize=TICK_PT - 1,
                color="white" if dark else "black",
                fontweight="bold" if dark else "normal",
                linespacing=1.1,
            )
        ax.set_xticks(range(nx), list(x_values))
        ax.set_yticks(range(ny), list(y_values))
        ax.set_xticks(np.arange(-0.5, nx), minor=True)
        ax.set_yticks(np.arange(-0.5, ny), minor=True)
        ax.grid(which="minor", color="white", linewidth=2)
        ax.tick_params(which="minor", length=0)
        ax.tick_params(labelsize=TICK_PT)
        ax.set_xlabel(x_name, fontsize=LABEL_PT)
        ax.set_ylabel(y_name, fontsize=LABEL_PT)
        if panel.title:
            ax.set_title(panel.title, fontsize=LABEL_PT)
    handles = [
        Patch(facecolor=COLORS[i % len(COLORS)], label=label) for i, label in enumerate(policies)
    ]
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncols=min(len(handles), 3),
        fontsize=TICK_PT,
        frameon=False,
        title=f"solid: significant win over the runner-up ({test_note} < {ALPHA:g})\n"
        "pale: not significant (n.s.)",
        title_fontsize=TICK_PT,
    )
    fig.suptitle(title, fontsize=TITLE_PT)
    return fig


def _cell_rgb(c: Cell) -> tuple[float, float, float]:
    if c.winner is None:
        return to_rgb(EMPTY)
    rgb = np.asarray(to_rgb(COLORS[c.winner % len(COLORS)]))
    if not c.significant:
        rgb = PALE * rgb + (1 - PALE) * np.ones(3)
    r, g, b = (float(v) for v in rgb)
    return (r, g, b)


@dataclass(frozen=True)
class Series:
    """One policy along the parameter: mean and 95% CI per value (None where no runs)."""

    label: str
    color: int
    means: Sequence[float | None]
    lows: Sequence[float | None]
    highs: Sequence[float | None]


def build_line_plot(
    title: str, x_name: str, x_values: Sequence[object], ylabel: str, series: Sequence[Series]
) -> Figure:
    """Mean per policy against the parameter, with its 95% CI; numeric values to scale."""
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in x_values)
    xs = np.asarray(x_values if numeric else range(len(x_values)), dtype=float)
    span = float(xs.max() - xs.min()) if xs.size > 1 else 1.0
    fig = Figure(figsize=(5.6, 3.9), layout="constrained")
    ax = fig.subplots()
    k = len(series)
    for j, s in enumerate(series):
        dx = (j - (k - 1) / 2) * 0.012 * (span or 1.0)  # dodge, so the intervals stay apart
        keep = [i for i, m in enumerate(s.means) if m is not None]
        if not keep:
            continue
        x = xs[keep] + dx
        m = np.asarray([s.means[i] for i in keep], dtype=float)
        lo = np.asarray([np.nan if s.lows[i] is None else s.lows[i] for i in keep], dtype=float)
        hi = np.asarray([np.nan if s.highs[i] is None else s.highs[i] for i in keep], dtype=float)
        err = np.vstack([np.nan_to_num(m - lo), np.nan_to_num(hi - m)])
        color = COLORS[s.color % len(COLORS)]
        ax.errorbar(
            x, m, yerr=err, fmt="-o", color=color, ms=4, capsize=3, linewidth=1.4, label=s.label
        )
    ax.set_xticks(xs, [_fmt(v) for v in x_values])
    ax.set_xlabel(x_name, fontsize=LABEL_PT)
    ax.set_ylabel(ylabel, fontsize=LABEL_PT)
    ax.tick_params(labelsize=TICK_PT)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=TICK_PT, frameon=False)
    fig.suptitle(title, fontsize=TITLE_PT)
    return fig


def _fmt(v: object) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)
