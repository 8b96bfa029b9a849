"""This server's size limits on a scenario, shared by missions and sweeps.

The engine validates a scenario on its own terms; a scenario it accepts can still be too big
for this server: a 6,000-robot team, or a search grid whose scanned bitmask rides in every
frame. Both a live mission and every run of a sweep build such a mission (a sweep's workers
grew to 3 GB before this check), so both refuse it the same way, before anything is built.
"""

from __future__ import annotations

import math

import numpy as np

from app.services.errors import Invalid
from app.settings import Settings
from engine import Scenario, ScenarioError
from engine.world import generate_world

Loc = tuple[str | int, ...]


def search_cells(scenario: Scenario) -> int:
    """Cells of the scouts' search grid (the engine's `make_grid` rounds each side up)."""
    cell = scenario.scan_radius * math.sqrt(2)
    return math.ceil(scenario.width / cell) * math.ceil(scenario.height / cell)


def check_size(
    settings: Settings, scenario: Scenario, loc: Loc = ("body", "scenario"), why: str = ""
) -> None:
    """422 (`Invalid`) naming the field if the team or the search grid exceeds this server's
    REGOLITH_MAX_ROBOTS or REGOLITH_MAX_GRID_CELLS; `why` says what made it that big."""
    team = scenario.team
    robots = team.scouts + team.excavators + team.haulers
    if robots > settings.max_robots:
        raise Invalid(
            f"team: {robots} robots{why} exceed this server's limit of "
            f"{settings.max_robots} (REGOLITH_MAX_ROBOTS)",
            (*loc, "team") if loc[-1] == "scenario" else loc,
        )
    cells = search_cells(scenario)
    if cells > settings.max_grid_cells:
        raise Invalid(
            f"width: a {scenario.width:g}×{scenario.height:g} area{why} scanned at radius "
            f"{scenario.scan_radius:g} has {cells} search cells, over this server's limit "
            f"of {settings.max_grid_cells} (REGOLITH_MAX_GRID_CELLS)",
            (*loc, "width") if loc[-1] == "scenario" else loc,
        )


def check_world(scenario: Scenario, seed: int, loc: Loc = ("body", "scenario")) -> None:
    """422 if the scenario cannot make a world for `seed` (sites that never fit). Only the
    world is generated (milliseconds, no planner, no gate), so a sweep whose every run would
    fail on it is refused up front instead."""
    world_rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(3)[0])
    try:
        generate_world(scenario, world_rng)
    except ScenarioError as exc:
        raise Invalid(str(exc), loc) from None
