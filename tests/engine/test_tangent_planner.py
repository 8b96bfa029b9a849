"""The exact planner: collision-free, shortest (against closed forms and a brute-force
visibility graph), never longer than RRT-Connect, deterministic inside a mission."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import run_mission
from engine.geometry import Point, path_length
from engine.planning import OmplPlanner, PlanningError
from engine.scenario import Crater
from engine.segment_grid import SegmentGrid, grid_step
from engine.tangent_planner import TangentPlanner
from engine.visibility_check import dense_visibility_length
from engine.world import CLEARANCE, CraterIndex, World
from tests.engine.factories import small_scenario


def world_of(craters: list[tuple[float, float, float]], side: float = 100.0) -> World:
    cs = tuple(Crater(x=x, y=y, r=r) for x, y, r in craters)
    return World(side, side, (side / 2, side / 2), cs, (), None, CraterIndex(cs))  # type: ignore[arg-type]


def assert_drivable(w: World, path: tuple[Point, ...], start: Point, goal: Point) -> None:
    assert path[0] == start and path[-1] == goal
    for a, b in itertools.pairwise(path):
        assert w.index.segment_free(a, b), (a, b)
        assert 0.0 <= b[0] <= w.width and 0.0 <= b[1] <= w.height


def test_one_crater_matches_the_closed_form() -> None:
    w = world_of([(50.0, 50.0, 5.0)])
    start, goal = (30.0, 50.0), (70.0, 50.0)
    path = TangentPlanner(w).plan(start, goal)
    assert_drivable(w, path, start, goal)
    r, d = 5.0 + CLEARANCE, 20.0
    alpha = math.acos(r / d)
    shortest = 2 * math.sqrt(d * d - r * r) + r * (math.pi - 2 * alpha)
    assert shortest <= path_length(path) <= shortest * 1.001


def test_two_overlapping_craters_are_one_obstacle() -> None:
    w = world_of([(45.0, 50.0, 5.0), (53.0, 50.0, 5.0)])
    start, goal = (49.0, 30.0), (49.0, 70.0)  # the gap between the rims is inside both
    path = TangentPlanner(w).plan(start, goal)
    assert_drivable(w, path, start, goal)
    assert path_length(path) > 40.0


def test_an_enclosed_goal_has_no_path() -> None:
    ring = [
        (50 + 9 * math.cos(a), 50 + 9 * math.sin(a), 3.0)
        for a in np.linspace(0, 2 * math.pi, 13)[:-1]
    ]
    w = world_of(ring)
    with pytest.raises(PlanningError):
        TangentPlanner(w).plan((10.0, 10.0), (50.0, 50.0))


crater = st.tuples(st.floats(20.0, 80.0), st.floats(20.0, 80.0), st.floats(2.0, 8.0))


@settings(max_examples=8, deadline=None)
@given(st.lists(crater, min_size=1, max_size=4), st.integers(0, 2**31 - 1))
def test_never_longer_than_brute_force_or_rrt_connect(
    craters: list[tuple[float, float, float]], seed: int
) -> None:
    w = world_of(craters)
    rng = np.random.default_rng(seed)
    exact = TangentPlanner(w)
    rrt = OmplPlanner(w, np.random.default_rng(seed))
    blocked = 0
    for _ in range(60):  # random pairs until three whose straight segment is blocked
        if blocked == 3:
            break
        start, goal = tuple(rng.uniform(0, 100, 2)), tuple(rng.uniform(0, 100, 2))
        if not (w.is_free(*start) and w.is_free(*goal)) or w.index.segment_free(start, goal):
            continue
        blocked += 1
        brute = dense_visibility_length(w, start, goal)
        try:
            path = exact.plan(start, goal)
        except PlanningError:
            assert brute == math.inf
            continue
        assert_drivable(w, path, start, goal)
        length = path_length(path)
        assert length <= brute * 1.0001  # the arcs are driven as polygons (≤ 0.05 % long)
        assert length <= path_length(rrt.plan(start, goal)) + 1e-6
    rrt.close()


def test_a_mission_on_the_exact_planner_is_deterministic_and_complete() -> None:
    scen = small_scenario(random_craters=4, crater_radius=(2.0, 4.0))
    first = run_mission(scen, 3, "lookahead", planner="exact")
    again = run_mission(scen, 3, "lookahead", planner="exact")
    assert first == again
    assert first["status"] == "completed"
    assert first["minerals_delivered"] == first["minerals_total"]


@pytest.mark.parametrize("n_craters", [5, 300])  # every disc at once, and the grid march
def test_the_segment_grid_agrees_with_the_crater_index(n_craters: int) -> None:
    rng = np.random.default_rng(n_craters)
    side = 400.0
    w = world_of(
        [(*rng.uniform(0, side, 2), rng.uniform(2.0, 5.0)) for _ in range(n_craters)], side
    )
    xyr = np.array([(c.x, c.y, c.r + CLEARANCE) for c in w.craters])
    grid = SegmentGrid(xyr, grid_step(xyr, side, side))
    a, b = rng.uniform(0, side, (3000, 2)), rng.uniform(0, side, (3000, 2))
    b[:1000] = a[:1000] + rng.normal(0, 6.0, (1000, 2))  # short ones, some grazing a rim
    b[1000:1010] = a[1000:1010]  # single points
    got = grid.free(a[:, 0], a[:, 1], b[:, 0], b[:, 1])
    want = [w.index.segment_free(tuple(p), tuple(q)) for p, q in zip(a, b, strict=True)]
    assert got.tolist() == want
    assert 0 < sum(want) < len(want)
