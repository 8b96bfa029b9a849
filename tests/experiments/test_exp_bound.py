"""The lower bound's terms on worlds small enough to compute by hand."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from experiments.bound import (
    _LEG_BLOCK,
    Bound,
    BoundWorld,
    bound_columns,
    found_bounds,
    lower_bound,
    mst_length,
    run_bound,
)
from experiments.bound import _legs_clear as legs_clear

BASE = BoundWorld(
    plant=(0.0, 0.0),
    sites=((10.0, 1.0, 2),),
    scout_routes=(((0.0, 0.0), (5.0, 0.0), (10.0, 0.0), (15.0, 0.0)),),
    start_spread=0.0,
    craters=(),
    clearance=0.51,
    scan_radius=2.0,
    scouts=1,
    excavators=1,
    haulers=1,
    v_scout=1.0,
    v_excavator=1.0,
    v_hauler=1.0,
    dig_s=3.0,
    transfer_s=1.0,
    unload_s=1.0,
)


def test_mst_length() -> None:
    assert mst_length([(0, 0), (1, 0), (1, 1), (0, 1)]) == pytest.approx(3.0)
    assert mst_length([(0, 0)]) == 0.0


def test_found_on_a_straight_leg_is_exact() -> None:
    # the x-axis first comes within 2 of (10, 1) at x = 10 − √3
    assert found_bounds(BASE)[0] == pytest.approx(10 - math.sqrt(3))


def test_a_blocked_leg_only_gives_the_reach_bound() -> None:
    w = replace(BASE, craters=((7.5, -2.0, 2.0),))  # blocks the leg (5,0)→(10,0)
    # on that leg the scout cannot be within 2 of the site before 5 + |(5,0)−(10,1)| − 2
    assert found_bounds(w)[0] == pytest.approx(5 + math.hypot(5, 1) - 2)


def test_terms_by_hand() -> None:
    b = lower_bound(BASE)
    d = math.hypot(10, 1)
    found = 10 - math.sqrt(3)
    arrive = max(found, d / 1.0)
    assert b.terms["chain"] == pytest.approx(arrive + 2 * (3 + 1) + d + 1)
    assert b.terms["haul_work"] == pytest.approx(2 * (2 * d + 1 + 1))
    # release: the second mineral is taken no earlier than arrive + 2 digs + 1 transfer
    second = arrive + 2 * 3 + 1
    assert b.terms["haul_release"] >= second + (2 * d + 2) - d
    assert b.value == max(b.terms.values())


def test_unreached_site_falls_back_to_reach() -> None:
    w = replace(BASE, sites=((0.0, 30.0, 1),))
    assert found_bounds(w)[0] == pytest.approx(30 - 2)


def test_run_bound_uses_the_actual_discovery_times() -> None:
    apriori = lower_bound(BASE)
    assert run_bound(BASE, list(apriori.found_s)).value == apriori.value  # type: ignore[union-attr]
    late = run_bound(BASE, [50.0])
    assert late is not None and late.terms["search_spiral"] == 50.0
    # found at 50: dug twice (4 s each with the transfer), then hauled home and unloaded
    assert late.terms["chain"] == pytest.approx(50 + 2 * 4 + math.hypot(10, 1) + 1)
    assert run_bound(BASE, [None]) is None and run_bound(BASE, []) is None


def test_bound_columns_per_run_and_apriori() -> None:
    def fn(scenario: object, seed: int) -> Bound:
        return lower_bound(BASE)

    rows: list[dict[str, Any]] = [
        {"seed": 0, "status": "completed", "makespan_s": 100.0, "sites_found_at": "[50.0]"},
        {"seed": 0, "status": "completed", "makespan_s": 90.0, "sites_found_at": [40.0]},
        {"seed": 0, "status": "timeout", "makespan_s": None, "sites_found_at": "[null]"},
        {"seed": 0, "status": "completed", "makespan_s": 90.0},  # no discovery times
    ]
    per_seed = bound_columns(rows, None, fn)
    apriori = lower_bound(BASE).value
    late = run_bound(BASE, [50.0])
    assert late is not None
    assert rows[0]["lower_bound_s"] == late.value and rows[0]["lower_bound_term"] == "haul_release"
    assert rows[0]["makespan_ratio"] == 100.0 / late.value
    assert rows[0]["makespan_ratio_apriori"] == 100.0 / apriori
    assert rows[1]["lower_bound_s"] < rows[0]["lower_bound_s"]
    for row in rows:
        assert row["lower_bound_apriori_s"] == apriori
    assert rows[2]["lower_bound_s"] is rows[2]["makespan_ratio"] is None
    assert rows[2]["makespan_ratio_apriori"] is None
    assert rows[3]["lower_bound_s"] is None and rows[3]["makespan_ratio_apriori"] is not None
    assert per_seed == [{"seed": 0, "lower_bound_apriori_s": apriori, **{
        f"{k}_s": v for k, v in lower_bound(BASE).terms.items()}}]  # fmt: skip


def test_legs_are_tested_against_every_crater_as_one_at_a_time_would() -> None:
    """The legs' crater test runs in blocks of legs against every crater at once; it answers
    as the plain loop does (closest point of the segment to each centre, past the inflated
    radius), across block boundaries and for legs of zero length."""
    rng = np.random.default_rng(5)
    craters = tuple(
        (float(x), float(y), float(r))
        for x, y, r in zip(
            rng.uniform(0, 200, 40), rng.uniform(0, 200, 40), rng.uniform(1, 8, 40), strict=True
        )
    )
    w = replace(BASE, craters=craters)
    route = rng.uniform(0, 200, (2 * _LEG_BLOCK + 7, 2))
    route[10] = route[9]  # a leg of zero length

    def plain(p: np.ndarray, q: np.ndarray) -> bool:
        dx, dy = q[0] - p[0], q[1] - p[1]
        seg2 = dx * dx + dy * dy
        for cx, cy, cr in craters:
            u = (
                0.0
                if seg2 == 0
                else min(1.0, max(0.0, ((cx - p[0]) * dx + (cy - p[1]) * dy) / seg2))
            )
            if math.hypot(p[0] + u * dx - cx, p[1] + u * dy - cy) <= cr + w.clearance:
                return False
        return True

    want = [plain(route[i], route[i + 1]) for i in range(len(route) - 1)]
    got = legs_clear(route, np.asarray(craters, dtype=float), w.clearance).tolist()
    assert got == want
    assert 0 < sum(want) < len(want)  # some legs clear, some blocked
    assert legs_clear(route, np.zeros((0, 3)), BASE.clearance).all()  # no craters: all clear
