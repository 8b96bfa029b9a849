"""Where an operator may put something: a robot's start or a task, checked against the map and
placed. A simulated mission and field mode's mission control check the same way, so one
request is refused (or snapped to a site) alike in both."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from engine.errors import CommandRejected
from engine.robots.scout import site_task_id

if TYPE_CHECKING:
    from engine.terrain import SiteState
    from engine.world import World

TASK_TYPES = ("excavate", "transport")


@dataclass(frozen=True)
class TaskPlacement:
    """An operator task checked and placed, not yet auctioned."""

    task_type: str
    x: float
    y: float
    task_id: str


def free_point(world: World, p: tuple[Any, ...], what: str) -> tuple[float, float]:
    """`p` as a point of the area outside every crater; `CommandRejected` naming `what`."""
    if len(p) != 2 or not all(isinstance(v, int | float) and math.isfinite(v) for v in p):
        raise CommandRejected(f"{what}: must be two finite numbers [x, y]")
    x, y = float(p[0]), float(p[1])
    if not (0 <= x <= world.width and 0 <= y <= world.height):
        raise CommandRejected(
            f"{what}: ({x:g}, {y:g}) is outside the area 0..{world.width:g} × 0..{world.height:g}"
        )
    if not world.is_free(x, y):
        raise CommandRejected(f"{what}: ({x:g}, {y:g}) lies in a crater")
    return x, y


def place_task(
    world: World,
    sites: Iterable[SiteState],
    scan_radius: float,
    task_type: str,
    location: Iterable[Any],
) -> TaskPlacement:
    """An operator task at `location`; an excavation snapped to the nearest site the robots
    know of within `scan_radius`, so the operator can point roughly at one."""
    if task_type not in TASK_TYPES:
        raise CommandRejected("type: must be 'excavate' or 'transport'")
    x, y = free_point(world, tuple(location), "location")
    if task_type == "excavate":
        near = [
            s
            for s in sites
            if s.found_at is not None and math.hypot(s.x - x, s.y - y) <= scan_radius
        ]
        if near:
            s = min(near, key=lambda s: (math.hypot(s.x - x, s.y - y), s.id))
            return TaskPlacement(task_type, s.x, s.y, site_task_id(s.x, s.y))
    return TaskPlacement(task_type, x, y, f"{task_type}@{x:.3f},{y:.3f}")
