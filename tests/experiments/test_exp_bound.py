"""The lower bound's terms on worlds small enough to compute by hand."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import pytest

from experiments.bound import (
    Bound,
    BoundWorld,
    bound_columns,
    found_bounds,
    lower_bound,
    mst_length,
    run_bound,
)

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
