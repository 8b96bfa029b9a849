"""The exact planner's goal fields (engine/tangent_field.py) give the lengths of the A* query
over the same graph (engine/tangent_query.py): on the reference world and its scale-10 and
scale-100 versions, for starts and goals anywhere, hugging a rim (just inside the planned rim
but outside the crater's clearance, or just outside it) and around one crater, with goals
shared by many starts as in an auction, and fields dropped and made again; and a start that
prices many goals, answered from its own field, gets each goal's own route."""

from __future__ import annotations

import math

import numpy as np
import pytest

import engine.tangent_planner
from engine import reference_scenario
from engine.geometry import Point, path_length
from engine.planning import PlanningError
from engine.tangent_planner import TangentPlanner
from engine.world import CLEARANCE, World, generate_world
from tests.engine.test_tangent_planner import assert_drivable, world_of

_NEAR = (5e-7, 2e-6, 1e-3, 0.5)
"""Distances from a crater's clearance: inside the planned rim (it is 1e-6 wider), just
outside it, close, near."""


def free_point(world: World, rng: np.random.Generator, near: Point | None = None) -> Point:
    """A free point: anywhere (or within 150 m of `near`), or beside a crater (at one of the
    `_NEAR` gaps)."""
    while True:
        if near is not None and rng.random() < 0.5:
            p = (near[0] + rng.uniform(-150, 150), near[1] + rng.uniform(-150, 150))
        elif rng.random() < 0.5:
            p = (float(rng.uniform(0, world.width)), float(rng.uniform(0, world.height)))
        else:
            c = world.craters[int(rng.integers(len(world.craters)))]
            a, gap = rng.uniform(0, 2 * math.pi), _NEAR[int(rng.integers(len(_NEAR)))]
            d = c.r + CLEARANCE + gap
            p = (c.x + d * math.cos(a), c.y + d * math.sin(a))
        if world.is_free(*p):
            return p


def length_or_inf(plan: object, start: Point, goal: Point) -> float:
    try:
        path = plan(start, goal)  # type: ignore[operator]
    except PlanningError:
        return math.inf
    return path_length(path)


def assert_field_matches_query(
    world: World, pairs: list[tuple[Point, Point]], planner: TangentPlanner | None = None
) -> None:
    planner = planner or TangentPlanner(world)
    graph = planner.graph
    for start, goal in pairs:
        want = length_or_inf(graph.shortest, start, goal)
        try:
            path = planner.plan(start, goal)
        except PlanningError:
            assert want == math.inf, (start, goal)
            continue
        assert_drivable(world, path, start, goal)
        assert path_length(path) == pytest.approx(want, rel=1e-9, abs=1e-9), (start, goal)


@pytest.mark.parametrize(("scale", "goals", "starts"), [(1, 6, 40), (10, 4, 40), (100, 2, 20)])
def test_the_goal_field_gives_the_querys_lengths(scale: int, goals: int, starts: int) -> None:
    """Starts anywhere, or within 150 m as in a mission (a query across scale 100's map is
    slow for the A* query, not for the field)."""
    world = generate_world(reference_scenario().scaled(scale), np.random.default_rng(scale))
    rng = np.random.default_rng(100 + scale)
    ends = [free_point(world, rng) for _ in range(goals)]
    pairs = [(free_point(world, rng, g), g) for g in ends for _ in range(starts)]
    pairs += [(g, free_point(world, rng)) for g in ends for _ in range(3)]  # goals as starts
    order = rng.permutation(len(pairs))  # the goals interleaved, as auctions overlap
    assert_field_matches_query(world, [pairs[i] for i in order])


def test_fields_dropped_and_made_again_give_the_same_paths(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(engine.tangent_planner, "_FIELDS", 3)
    monkeypatch.setattr(engine.tangent_planner, "_FIELD_BYTES", 0)
    monkeypatch.setattr(engine.tangent_planner, "_FANS", 5)
    world = generate_world(reference_scenario(), np.random.default_rng(7))
    rng = np.random.default_rng(7)
    ends = [free_point(world, rng) for _ in range(8)]  # more than are kept
    pairs = [(free_point(world, rng), ends[int(rng.integers(len(ends)))]) for _ in range(150)]
    pairs += [(start, ends[-1]) for start, _ in pairs[:20]]  # starts again, their fans kept
    planner = TangentPlanner(world)
    assert_field_matches_query(world, pairs, planner)
    assert len(planner._fields) == 3 and len(planner._fans) == 5
    again = TangentPlanner(world)  # the same queries, fresh: the same paths, bit for bit
    backwards = TangentPlanner(world)  # the other way round: fields reach other limits
    for start, goal in pairs[::-1]:
        assert length_or_inf(backwards.plan, start, goal) == pytest.approx(
            length_or_inf(planner.plan, start, goal), rel=1e-9
        )
    for start, goal in pairs:
        try:
            assert again.plan(start, goal) == planner.plan(start, goal)
        except PlanningError:
            with pytest.raises(PlanningError):
                planner.plan(start, goal)


def test_around_one_crater_and_between_two() -> None:
    """No node on the rim but the query's own (one crater), or a route between the start's
    and the goal's tangents on one rim with nodes on it (two craters)."""
    rng = np.random.default_rng(3)
    for craters in ([(50.0, 50.0, 8.0)], [(50.0, 50.0, 8.0), (75.0, 52.0, 6.0)]):
        world = world_of(craters)
        pairs = []
        for _ in range(40):
            a = rng.uniform(0, 2 * math.pi)
            d = 8.0 + CLEARANCE + _NEAR[int(rng.integers(len(_NEAR)))]
            start = (50 + d * math.cos(a), 50 + d * math.sin(a))
            goal = (50 - 20 * math.cos(a + rng.normal(0, 0.3)), 50 - 20 * math.sin(a))
            if world.is_free(*start) and world.is_free(*goal):
                pairs += [(start, goal), (goal, start)]
        assert len(pairs) > 40
        assert_field_matches_query(world, pairs)


@pytest.mark.parametrize(("scale", "starts"), [(1, 40), (10, 30), (100, 12)])
def test_a_start_pricing_many_goals_gets_each_goals_own_route(scale: int, starts: int) -> None:
    """A start that prices goal after goal whose fields are not kept is answered from its
    own field, the route found from the goal driven backwards (`TangentPlanner._sweeping`,
    `_backwards`). Bids, and so every event log, are computed from the polyline, so it must
    be the goal field's point for point, not only as long: starts anywhere and beside
    craters, several goals each."""
    world = generate_world(reference_scenario().scaled(scale), np.random.default_rng(scale + 5))
    rng = np.random.default_rng(200 + scale)
    by_goal, by_start = TangentPlanner(world), TangentPlanner(world)
    by_start._graph, by_start._flat = by_goal.graph, by_goal.flat  # one graph opened, not two
    by_start._fields_kept = by_goal._fields_kept
    points = [free_point(world, rng) for _ in range(starts)]
    blocked = 0
    for start in points:
        for k in rng.choice(len(points), 6, replace=False).tolist():
            goal = points[k]
            if goal == start:
                continue
            by_goal._sweep = (None, 0)  # the goal's field answers
            by_start._sweep = (start, 99)  # the start's field answers
            try:
                want = by_goal.plan(start, goal)
            except PlanningError:
                with pytest.raises(PlanningError):
                    by_start.plan(start, goal)
                continue
            got = by_start.plan(start, goal)
            assert got == want, (start, goal)
            blocked += len(want) > 2
    assert blocked > 20  # most pairs go round a crater: the fields were asked


def test_a_start_that_prices_many_goals_makes_one_field_not_one_per_goal() -> None:
    """Policy 3's excavator after a dig prices every waiting site: from the second goal in a
    row whose field is not kept, its own field answers the rest, so the fields other robots
    share stay kept."""
    world = generate_world(reference_scenario().scaled(10), np.random.default_rng(11))
    rng = np.random.default_rng(12)
    planner = TangentPlanner(world)
    start = free_point(world, rng)
    goals = [free_point(world, rng) for _ in range(40)]
    made: list[Point] = []
    field = planner.field

    def counted(goal: Point) -> object:
        if goal not in planner._fields:
            made.append(goal)
        return field(goal)

    planner.field = counted  # type: ignore[method-assign]
    answered = [planner.plan(start, g) for g in goals]
    blocked = [g for g, path in zip(goals, answered, strict=True) if len(path) > 2]
    assert len(blocked) > 10
    assert made == [blocked[0], start]
