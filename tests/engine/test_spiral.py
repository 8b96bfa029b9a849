"""docs/spec.md §7: every cell scanned exactly once across all scouts, nearest cells first."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import Mission, reference_scenario
from engine.spiral import spiral_routes
from engine.world import generate_world, make_grid
from tests.engine.factories import small_scenario


def scannable(grid) -> set[int]:
    return {i for i, wp in enumerate(grid.waypoints) if wp is not None}


@given(
    scouts=st.integers(1, 7),
    width=st.floats(10, 150),
    height=st.floats(10, 150),
    px=st.floats(0, 1),
    py=st.floats(0, 1),
)
@settings(max_examples=60, deadline=None)
def test_routes_cover_every_cell_exactly_once(scouts, width, height, px, py):
    s = small_scenario(
        width=width,
        height=height,
        plant=(px * width, py * height),
        sites=1,
        minerals=1,
        random_craters=0,
        start_spread=0.0,
    )
    grid = make_grid(s, ())
    routes = spiral_routes(grid, s.plant_xy, scouts)
    cells = [c for r in routes for c in r]
    assert len(cells) == len(set(cells)), "a cell is scanned twice"
    assert set(cells) == scannable(grid), "a cell is missed"


def test_cells_small_enough_that_the_scan_circle_covers_them():
    s = reference_scenario()
    grid = make_grid(s, ())
    half_diagonal = math.hypot(grid.cell_w, grid.cell_h) / 2
    assert half_diagonal <= s.scan_radius


def test_each_scouts_route_moves_outward_from_the_plant():
    s = reference_scenario()
    world = generate_world(s, np.random.default_rng(0))
    routes = spiral_routes(world.grid, world.plant, 2)
    pc = world.grid.cell_of(*world.plant)
    pr, pcol = divmod(pc, world.grid.cols)
    for route in routes:
        rings = [
            max(abs(c // world.grid.cols - pr), abs(c % world.grid.cols - pcol)) for c in route
        ]
        assert rings == sorted(rings), "a scout went back to an inner ring"


def test_a_whole_mission_scans_every_scannable_cell_once():
    m = Mission(reference_scenario(), seed=5, policy="fcfs")
    m.advance(1e6)
    assert m.ctx.terrain.scanned_count == len(scannable(m.world.grid))
