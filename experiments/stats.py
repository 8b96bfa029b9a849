"""The statistics of a policy comparison: descriptive summaries, tests, corrections, effects.

Pure functions on plain sequences, so they are checked against scipy on known data. Runs
are the unit of the unpaired tests; when every policy ran the same seeds (a sweep always
does), the per-seed differences are the unit of the paired tests, which then decide.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
from scipy import stats as sps  # type: ignore[import-untyped]

Values = Sequence[float | None] | np.ndarray
"""One value per run; None (or NaN) where a run has no value for the metric."""

CONFIDENCE = 0.95
ALPHA = 0.05


def _clean(x: Values) -> np.ndarray:
    """Drop missing values: a metric absent from a run (e.g. no auctions of a kind) has no value."""
    arr = np.asarray([v for v in x if v is not None], dtype=float)
    out: np.ndarray = arr[np.isfinite(arr)]
    return out


@dataclass(frozen=True)
class Describe:
    n: int
    mean: float | None
    std: float | None
    ci_low: float | None
    ci_high: float | None
    median: float | None
    min: float | None
    max: float | None

    @property
    def half_width(self) -> float | None:
        if self.ci_high is None or self.mean is None:
            return None
        return self.ci_high - self.mean

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["ci95"] = [d.pop("ci_low"), d.pop("ci_high")]
        return d


def describe(x: Values, confidence: float = CONFIDENCE) -> Describe:
    """n, mean, sample std (ddof=1) and the t-based CI of the mean (none for n < 2)."""
    a = _clean(x)
    n = int(a.size)
    if n == 0:
        return Describe(0, None, None, None, None, None, None, None)
    mean = float(a.mean())
    if n < 2:
        return Describe(1, mean, None, None, None, mean, mean, mean)
    std = float(a.std(ddof=1))
    half = float(sps.t.ppf(0.5 + confidence / 2, n - 1)) * std / math.sqrt(n)
    return Describe(
        n, mean, std, mean - half, mean + half, float(np.median(a)), float(a.min()), float(a.max())
    )


def welch_p(a: Values, b: Values) -> float | None:
    """Two-sided Welch t-test p-value; two constant samples give 1 if equal, else 0."""
    x, y = _clean(a), _clean(b)
    if x.size < 2 or y.size < 2:
        return None
    if x.std() == 0 and y.std() == 0:
        return 1.0 if x.mean() == y.mean() else 0.0
    with warnings.catch_warnings():  # near-identical samples: scipy warns, the p-value stands
        warnings.simplefilter("ignore", RuntimeWarning)
        return float(sps.ttest_ind(x, y, equal_var=False).pvalue)


def mann_whitney(a: Values, b: Values) -> tuple[float, float] | None:
    """Two-sided Mann–Whitney U (U of `a`, p-value); no test if every value is tied."""
    x, y = _clean(a), _clean(b)
    if x.size == 0 or y.size == 0:
        return None
    if np.unique(np.concatenate([x, y])).size == 1:
        return float(x.size * y.size / 2), 1.0
    res = sps.mannwhitneyu(x, y, alternative="two-sided")
    return float(res.statistic), float(res.pvalue)


def cohen_d(a: Values, b: Values) -> float | None:
    """(mean a − mean b) / pooled sd; positive when `a` is larger."""
    x, y = _clean(a), _clean(b)
    if x.size < 2 or y.size < 2:
        return None
    pooled = ((x.size - 1) * x.var(ddof=1) + (y.size - 1) * y.var(ddof=1)) / (x.size + y.size - 2)
    if pooled == 0:
        return 0.0 if x.mean() == y.mean() else math.copysign(math.inf, x.mean() - y.mean())
    return float((x.mean() - y.mean()) / math.sqrt(pooled))


def rank_biserial(u_a: float, n_a: int, n_b: int) -> float:
    """2·U_a/(n_a·n_b) − 1 in [−1, 1]; positive when `a` tends to be larger."""
    return 2.0 * u_a / (n_a * n_b) - 1.0


def holm(pvalues: Sequence[float | None]) -> list[float | None]:
    """Holm's step-down adjustment (as R's `p.adjust(method="holm")`); None stays None."""
    idx = [i for i, p in enumerate(pvalues) if p is not None]
    m = len(idx)
    order = sorted(idx, key=lambda i: (pvalues[i], i))
    out: list[float | None] = [None] * len(pvalues)
    running = 0.0
    for rank, i in enumerate(order):
        p = pvalues[i]
        assert p is not None
        running = max(running, min(1.0, (m - rank) * p))
        out[i] = running
    return out


def paired(
    a: Sequence[float | None], b: Sequence[float | None]
) -> tuple[int, float | None, float | None]:
    """Paired t-test and Wilcoxon signed-rank p-values over positions where both have a value.

    Every policy runs the same seeds, so run i of a and run i of b share their world; pairing
    removes the world-to-world spread that the unpaired tests must carry.
    """
    both = [(float(x), float(y)) for x, y in zip(a, b, strict=True) if _ok(x) and _ok(y)]  # type: ignore[arg-type]
    n = len(both)
    if n < 2:
        return n, None, None
    diff = np.asarray([x - y for x, y in both], dtype=float)
    if np.all(diff == 0):
        return n, 1.0, 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        if np.all(diff == diff[0]):  # a constant nonzero difference: no spread to test
            t_p = 0.0
        else:
            t_p = float(sps.ttest_rel([x for x, _ in both], [y for _, y in both]).pvalue)
        w_p = float(sps.wilcoxon(diff).pvalue)
    return n, t_p, w_p


def _ok(v: float | None) -> bool:
    return v is not None and math.isfinite(v)


TESTS = ("welch", "mwu", "paired_t", "wilcoxon")
"""The four tests of a comparison; each has `<test>_p_raw` and `<test>_p_adj`."""


def paired_diffs(a: Sequence[float | None], b: Sequence[float | None]) -> np.ndarray:
    """a[i] − b[i] at every position (seed) where both have a value."""
    out = [float(x) - float(y) for x, y in zip(a, b, strict=True) if _ok(x) and _ok(y)]  # type: ignore[arg-type]
    return np.asarray(out, dtype=float)


@dataclass(frozen=True)
class Comparison:
    """One metric, one pair of policies: `a` minus `b`.

    Every p-value is labelled: `_p_raw` is the test's own, `_p_adj` is Holm-adjusted over
    the family the comparison belongs to (set by whoever builds the family: `pairwise` uses
    the pairs of one metric, `adjust_family` any set of metrics' pairs).
    """

    a: str
    b: str
    n_a: int
    n_b: int
    mean_diff: float | None
    welch_p_raw: float | None
    welch_p_adj: float | None
    mwu_u: float | None
    mwu_p_raw: float | None
    mwu_p_adj: float | None
    cohen_d: float | None
    rank_biserial: float | None
    n_pairs: int = 0
    paired_t_p_raw: float | None = None
    paired_t_p_adj: float | None = None
    wilcoxon_p_raw: float | None = None
    wilcoxon_p_adj: float | None = None
    paired_mean_diff: float | None = None
    paired_ci95: tuple[float | None, float | None] = (None, None)
    paired_median_diff: float | None = None
    a_lower: int = 0  # seeds on which a's value is below b's
    b_lower: int = 0

    @property
    def paired_design(self) -> bool:
        """Runs matched by seed and enough pairs to test: the paired test decides."""
        return self.paired_t_p_raw is not None

    @property
    def primary_test(self) -> str:
        """The verdict's test: paired t on per-seed differences if paired, else Welch."""
        return "paired_t" if self.paired_design else "welch"

    def p_adj(self, test: str) -> float | None:
        value: float | None = getattr(self, f"{test}_p_adj")
        return value

    @property
    def significant(self) -> bool:
        """The verdict: the primary test's adjusted p below α."""
        p = self.p_adj(self.primary_test)
        return p is not None and p < ALPHA

    @property
    def significant_welch(self) -> bool:
        return self.welch_p_adj is not None and self.welch_p_adj < ALPHA

    @property
    def significant_paired(self) -> bool:
        return self.paired_t_p_adj is not None and self.paired_t_p_adj < ALPHA

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["paired_ci95"] = list(self.paired_ci95)
        d["primary_test"] = self.primary_test
        d["significant"] = self.significant
        d["significant_welch"] = self.significant_welch
        d["significant_paired"] = self.significant_paired
        return d


def pairwise(
    groups: Mapping[str, Sequence[float | None]], aligned: bool = False
) -> list[Comparison]:
    """Every pair of groups (in the given order), Holm-corrected within this metric.

    The family here is the k·(k−1)/2 pairs of one metric; each test's p-values are corrected
    separately (`adjust_family` widens the family over several metrics). With `aligned`
    (position i of every group is the same seed) the paired tests and the per-seed
    differences are added.
    """
    names = list(groups)
    out = []
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            out.append(_compare(a, b, groups[a], groups[b], aligned))
    return adjust_family([out])[0]


def _compare(
    a: str, b: str, ga: Sequence[float | None], gb: Sequence[float | None], aligned: bool
) -> Comparison:
    x, y = _clean(ga), _clean(gb)
    mw = mann_whitney(x, y)
    c = Comparison(
        a=a,
        b=b,
        n_a=int(x.size),
        n_b=int(y.size),
        mean_diff=float(x.mean() - y.mean()) if x.size and y.size else None,
        welch_p_raw=welch_p(x, y),
        welch_p_adj=None,
        mwu_u=mw[0] if mw else None,
        mwu_p_raw=mw[1] if mw else None,
        mwu_p_adj=None,
        cohen_d=cohen_d(x, y),
        rank_biserial=rank_biserial(mw[0], x.size, y.size) if mw else None,
    )
    if not aligned:
        return c
    n, t_p, w_p = paired(ga, gb)
    diffs = paired_diffs(ga, gb)
    d = describe(diffs)
    return replace(
        c,
        n_pairs=n,
        paired_t_p_raw=t_p,
        wilcoxon_p_raw=w_p,
        paired_mean_diff=d.mean,
        paired_ci95=(d.ci_low, d.ci_high),
        paired_median_diff=d.median,
        a_lower=int((diffs < 0).sum()),
        b_lower=int((diffs > 0).sum()),
    )


def adjust_family(families: Sequence[Sequence[Comparison]]) -> list[list[Comparison]]:
    """Holm-adjust each test's raw p-values over every comparison of `families` together.

    The family is the union (e.g. every pair of policies on every metric a report draws
    verdicts on); the result keeps the input's nesting. A missing p-value stays missing and
    does not count towards the family's size.
    """
    flat = [c for fam in families for c in fam]
    adjusted = {t: holm([getattr(c, f"{t}_p_raw") for c in flat]) for t in TESTS}
    new = [
        replace(
            c,
            welch_p_adj=adjusted["welch"][i],
            mwu_p_adj=adjusted["mwu"][i],
            paired_t_p_adj=adjusted["paired_t"][i],
            wilcoxon_p_adj=adjusted["wilcoxon"][i],
        )
        for i, c in enumerate(flat)
    ]
    out, at = [], 0
    for fam in families:
        out.append(new[at : at + len(fam)])
        at += len(fam)
    return out
