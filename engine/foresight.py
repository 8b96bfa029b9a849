"""What the offline reference foresees: when the scouts will find each site, and the paths.

`predict_found` drives every working scout's remaining spiral on paper along the run planner's
own paths; `SnappingPlanner` makes the legs robots drive the legs the plan measured. Both are
for `engine.offline` only (the clairvoyant reference, docs/policies.md).
"""

from __future__ import annotations

import itertools
import math
from typing import TYPE_CHECKING

from engine.geometry import Point, dist, first_entry
from engine.planning import Path, PathPlanner, PlanningError

if TYPE_CHECKING:
    from engine.global_view import GlobalView


def predict_found(ctx: GlobalView) -> dict[str, float]:
    """When each site not yet found will be, by driving every working scout's remaining route
    on paper, along the paths the run's planner gives: the fixed spiral of docs/spec.md §7."""
    now, r = float(ctx.env.now), ctx.scenario.scan_radius
    wps = ctx.world.grid.waypoints
    out: dict[str, float] = {}
    for scout in sorted(ctx.robots.values(), key=lambda r: r.name):
        search = scout.search
        if search is None or not scout.participating:
            continue
        route, cursor = search.route, search.cursor
        here = scout.mobility.position()[0]
        points: list[Point] = [here]
        if scout.motion is not None:
            points += scout.mobility.remaining_route()[1:]
            cursor += 1
        points += [p for c in route[cursor:] if (p := wps[c]) is not None]
        t = now
        for a0, b0 in itertools.pairwise(points):
            for a, b in legs(ctx, a0, b0):
                secs = dist(a, b) / scout.speed
                if secs <= 0.0:
                    continue
                for site in ctx.terrain.sites_near(a, b, r):
                    if site.found_at is not None:
                        continue
                    u = first_entry(a, b, (site.x, site.y), r)
                    if u is not None:
                        seen = t + u * secs
                        if seen < out.get(site.id, math.inf):
                            out[site.id] = seen
                t += secs
    return out


def legs(ctx: GlobalView, a: Point, b: Point) -> list[tuple[Point, Point]]:
    """The segments of the path a scout drives from a to b (the run's own planner: its per-run
    cache then gives the scout this very path when it gets there)."""
    if ctx.world.index.segment_free(a, b):
        return [(a, b)]
    try:
        path = ctx.planner.plan(a, b)
    except PlanningError:
        return [(a, b)]
    return list(itertools.pairwise(path))


SNAP = 1e-6
"""Two query ends this close (metres) are the same point for `SnappingPlanner`."""


class SnappingPlanner:
    """The run's planner, remembering one path per crater-blocked leg while `offline` rules.

    A robot that drove to a point stands there only up to rounding (a few ulps off), and the
    run's planner caches paths by the exact query, so the same leg driven twice would get a
    fresh random RRT-Connect path each time — and the plan's estimate of it (one such path)
    would be a coin toss. Here a query whose ends lie within `SNAP` of a remembered leg's gets
    that leg's path, its ends moved onto the query's (if those short end pieces are clear):
    the plan's legs are the legs driven. Straight legs are unchanged (the planner returns the
    segment), and under any other policy every query goes straight to the run's planner.
    """

    def __init__(self, inner: PathPlanner, ctx: GlobalView) -> None:
        self.inner = inner
        self.stats = inner.stats
        self._ctx = ctx
        self._legs: dict[tuple[tuple[int, int], tuple[int, int]], Path] = {}

    def plan(self, start: Point, goal: Point) -> Path:
        ctx = self._ctx
        index = ctx.world.index
        if ctx.policy.name != "offline" or index.segment_free(start, goal):
            return self.inner.plan(start, goal)
        key = (_snap(start), _snap(goal))
        known = self._legs.get(key)
        if known is not None and len(known) > 2:
            moved = (start, *known[1:-1], goal)
            if index.segment_free(start, moved[1]) and index.segment_free(moved[-2], goal):
                self.stats.queries += 1
                self.stats.cached += 1
                return moved
        path = self.inner.plan(start, goal)
        self._legs.setdefault(key, path)
        return path

    def close(self) -> None:
        self.inner.close()


def _snap(p: Point) -> tuple[int, int]:
    return round(p[0] / SNAP), round(p[1] / SNAP)
