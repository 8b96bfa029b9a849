"""How far each field robot has travelled, from what mission control hears of it.

A field robot is a process of its own: mission control never steps it, so it cannot read an
odometer the way the engine's metrics do. What it hears is a heartbeat every few simulated
seconds with the robot's position and the route ahead. Between two heartbeats the robot
followed the route the first one announced, so the distance is measured along that route up
to where the second heartbeat puts it; a position off that route (a new plan, a robot
restarted elsewhere) counts the straight line, which never overstates.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence

from engine.messages import Heartbeat

Point = tuple[float, float]

#: How far (m) a heard position may lie from the announced route and still be on it.
ON_ROUTE_M = 1.0


def along(route: Sequence[Point], p: Point) -> float | None:
    """The distance along `route` to the point on it nearest `p`, or None if `p` lies off it."""
    best: tuple[float, float] | None = None  # (distance from the route, distance along it)
    walked = 0.0
    for a, b in itertools.pairwise(route):
        dx, dy = b[0] - a[0], b[1] - a[1]
        seg = math.hypot(dx, dy)
        u = (
            0.0
            if seg == 0
            else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / seg**2))
        )
        off = math.hypot(a[0] + u * dx - p[0], a[1] + u * dy - p[1])
        if best is None or off < best[0] - 1e-9:
            best = (off, walked + u * seg)
        walked += seg
    if best is None or best[0] > ON_ROUTE_M:
        return None
    return best[1]


def route_of(hb: Heartbeat) -> list[Point]:
    """The route a heartbeat announced, from where the robot stood."""
    return [(hb.x, hb.y), *((float(q[0]), float(q[1])) for q in hb.path)]


class Odometer:
    """Metres travelled per robot, summed heartbeat to heartbeat."""

    def __init__(self) -> None:
        self.metres: dict[str, float] = {}
        self._last: dict[str, Heartbeat] = {}
        self._where: dict[str, Point] = {}

    def heard(self, latest: Iterable[tuple[str, Heartbeat]]) -> None:
        """Each robot's latest heartbeat (the same one heard twice adds nothing)."""
        for name, hb in latest:
            if self._last.get(name) is not hb:
                self._step(name, hb)

    def _step(self, name: str, hb: Heartbeat) -> None:
        prev = self._last.get(name)
        here = (hb.x, hb.y)
        step: float | None = None
        if prev is not None:
            step = along(route_of(prev), here)
        if step is None:
            was = self._where.get(name, here)
            step = math.hypot(here[0] - was[0], here[1] - was[1])
        self.metres[name] = self.metres.get(name, 0.0) + step
        self._last[name] = hb
        self._where[name] = here

    def metrics(self) -> dict[str, object]:
        """`distance` by robot type and `distance_total`, as the engine's metrics name them."""
        by_type = dict.fromkeys(("scout", "excavator", "hauler"), 0.0)
        for name, metres in self.metres.items():
            rtype = name.rsplit("-", 1)[0]
            if rtype in by_type:
                by_type[rtype] += metres
        return {"distance": by_type, "distance_total": sum(by_type.values())}
