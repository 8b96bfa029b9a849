"""The lower bound's terms on worlds small enough to compute by hand."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from experiments.bound import BoundWorld, found_bounds, lower_bound, mst_length

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
