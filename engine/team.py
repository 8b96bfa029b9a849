"""A mission's team: the robots' names, where they start, the scouts' routes and each robot
built as its type's class. A simulated mission and field mode's world service and agents all
build their team here, so a robot has the same name, start and route in both."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from engine.robots import OPERATOR, Excavator, Hauler, Operator, Robot, Scout
from engine.scenario import ROBOT_TYPES
from engine.spiral import spiral_routes

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.geometry import Point
    from engine.scenario import Team
    from engine.world import World

CLASSES: dict[str, type[Robot]] = {"scout": Scout, "excavator": Excavator, "hauler": Hauler}


def robot_name(rtype: str, n: int) -> str:
    """The `n`th robot of a type (from 1): `hauler-3`."""
    return f"{rtype}-{n}"


def robot_type(name: str) -> str:
    """The type a robot's name says (`hauler-3` → `hauler`; the operator's console's own)."""
    return OPERATOR if name == OPERATOR else name.rsplit("-", 1)[0]


def check_type(rtype: str) -> None:
    """ValueError unless `rtype` is a robot type an operator may add."""
    if rtype not in ROBOT_TYPES:
        raise ValueError(f"type: must be one of {', '.join(ROBOT_TYPES)}")


def roster(team: Team) -> dict[str, str]:
    """The starting team, name → type, in the order it is built: scouts, excavators, haulers."""
    counts = {"scout": team.scouts, "excavator": team.excavators, "hauler": team.haulers}
    return {robot_name(t, i + 1): t for t, n in counts.items() for i in range(n)}


def start_positions(world: World, spread: float, n: int) -> list[Point]:
    """`n` robots on a ring of radius `spread` around the plant, evenly spread."""
    px, py = world.plant
    out = []
    for i in range(n):
        a = 2 * math.pi * i / max(1, n)
        x = min(max(px + spread * math.cos(a), 0.0), world.width)
        y = min(max(py + spread * math.sin(a), 0.0), world.height)
        out.append((round(x, 6), round(y, 6)))
    return out


def scout_routes(world: World, scouts: int) -> dict[str, list[int]]:
    """Each starting scout's spiral route (cell indices), by name."""
    routes = spiral_routes(world.grid, world.plant, scouts)
    return {robot_name("scout", i + 1): r for i, r in enumerate(routes)}


def build_robot(
    name: str, rtype: str, ctx: MissionContext, pos: Point, routes: dict[str, list[int]]
) -> Robot:
    """The robot `name` as its type's class at `pos`, at its scenario's speed (the operator's
    console: an auctioneer with no body; a scout: given the starting scouts' `routes`)."""
    if rtype == OPERATOR:
        return Operator(name, ctx, pos, 1.0)
    speed = getattr(ctx.scenario.speeds, rtype)
    if rtype == "scout":
        return Scout(name, ctx, pos, speed, routes)
    return CLASSES[rtype](name, ctx, pos, speed)
