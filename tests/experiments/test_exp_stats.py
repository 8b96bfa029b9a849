"""The statistics against scipy and against values computed by hand or by R."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats as sps

from experiments.stats import (
    cohen_d,
    describe,
    holm,
    mann_whitney,
    pairwise,
    rank_biserial,
    welch_p,
)

A = [12.1, 9.8, 11.4, 10.2, 13.5, 10.9, 11.7, 9.5]
B = [14.2, 13.1, 12.8, 15.5, 13.9, 12.2, 14.8]


def test_describe_matches_scipy_t_interval() -> None:
    d = describe(A)
    lo, hi = sps.t.interval(0.95, len(A) - 1, loc=np.mean(A), scale=sps.sem(A))
    assert d.n == 8
    assert d.mean == pytest.approx(np.mean(A))
    assert d.std == pytest.approx(np.std(A, ddof=1))
    assert (d.ci_low, d.ci_high) == (pytest.approx(lo), pytest.approx(hi))
    assert d.median == pytest.approx(np.median(A))


def test_describe_known_values() -> None:
    d = describe([1.0, 2.0, 3.0, 4.0, 5.0])  # sd=√2.5, t(0.975, 4)=2.776445
    assert d.half_width == pytest.approx(2.776445 * math.sqrt(2.5) / math.sqrt(5), rel=1e-6)


def test_describe_small_and_missing() -> None:
    assert describe([]).mean is None
    one = describe([None, 4.0, float("nan")])
    assert (one.n, one.mean, one.std, one.ci_low) == (1, 4.0, None, None)


def test_welch_matches_scipy() -> None:
    assert welch_p(A, B) == pytest.approx(sps.ttest_ind(A, B, equal_var=False).pvalue)
    assert welch_p([5.0, 5.0], [5.0, 5.0]) == 1.0
    assert welch_p([5.0, 5.0], [6.0, 6.0]) == 0.0
    assert welch_p([1.0], B) is None


def test_mann_whitney_matches_scipy() -> None:
    res = sps.mannwhitneyu(A, B, alternative="two-sided")
    u, p = mann_whitney(A, B) or (None, None)
    assert (u, p) == (pytest.approx(res.statistic), pytest.approx(res.pvalue))
    assert mann_whitney([1.0, 1.0], [1.0]) == (1.0, 1.0)


def test_effect_sizes() -> None:
    # pooled variance of these two is 2.5, difference of means −2
    assert cohen_d([1, 2, 3, 4, 5], [3, 4, 5, 6, 7]) == pytest.approx(-2 / math.sqrt(2.5))
    u, _ = mann_whitney([1.0, 2.0, 3.0], [4.0, 5.0]) or (0.0, 0.0)
    assert rank_biserial(u, 3, 2) == -1.0  # every a below every b
    assert rank_biserial(6.0, 3, 2) == 1.0


def test_holm_matches_r_p_adjust() -> None:
    # R: p.adjust(c(0.50,0.01,0.001,0.69,0.02,0.05,0.0025), "holm")
    raw = [0.50, 0.01, 0.001, 0.69, 0.02, 0.05, 0.0025]
    want = [1.0, 0.05, 0.007, 1.0, 0.08, 0.15, 0.015]
    assert holm(raw) == [pytest.approx(w) for w in want]
    assert holm([None, 0.02, 0.04]) == [None, pytest.approx(0.04), pytest.approx(0.04)]


@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=12))
def test_holm_is_a_valid_adjustment(ps: list[float]) -> None:
    adj = holm(ps)
    assert all(a is not None and p <= a + 1e-15 and a <= 1.0 for p, a in zip(ps, adj, strict=True))
    order = sorted(range(len(ps)), key=lambda i: ps[i])
    ranked = [adj[i] for i in order]
    assert ranked == sorted(ranked)  # type: ignore[type-var]


def test_pairwise_corrects_within_the_metric() -> None:
    rng = np.random.default_rng(1)
    groups = {k: list(rng.normal(m, 1.0, 30)) for k, m in (("p1", 10), ("p2", 10.1), ("p3", 12))}
    out = pairwise(groups)
    assert [(c.a, c.b) for c in out] == [("p1", "p2"), ("p1", "p3"), ("p2", "p3")]
    raw = [welch_p(groups[c.a], groups[c.b]) for c in out]
    assert [c.welch_p_raw for c in out] == raw
    assert [c.welch_p_adj for c in out] == holm(raw)
    assert out[1].significant and not out[0].significant
    assert out[1].cohen_d is not None and out[1].cohen_d < 0
