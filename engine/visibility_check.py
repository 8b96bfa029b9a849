"""An independent check of the exact planner's shortest paths, for tests and the bench."""

from __future__ import annotations

import heapq
import math

from engine.geometry import Point, dist
from engine.world import CLEARANCE, World


def dense_visibility_length(world: World, start: Point, goal: Point, per_rim: int = 72) -> float:
    """An independent check of the tangent graph, for tests and the bench (slow: O(n²)).

    Dijkstra over a dense visibility graph of points just outside every rim: every route it
    finds is drivable, so its length bounds the shortest from above and converges to it as
    `per_rim` grows. The tangent graph's route is never longer (but for its polygonal arcs).
    """
    pts = [start, goal]
    for c in world.craters:
        big = (c.r + CLEARANCE) * 1.0001 / math.cos(math.pi / per_rim) + 1e-6
        for k in range(per_rim):
            a = 2 * math.pi * k / per_rim
            p = (c.x + big * math.cos(a), c.y + big * math.sin(a))
            if world.is_free(*p):
                pts.append(p)
    best, heap = {0: 0.0}, [(0.0, 0)]
    while heap:
        g, u = heapq.heappop(heap)
        if u == 1:
            return g
        if g > best.get(u, math.inf):
            continue
        for v, p in enumerate(pts):
            ng = g + dist(pts[u], p)
            if v != u and ng < best.get(v, math.inf) and world.index.segment_free(pts[u], p):
                best[v] = ng
                heapq.heappush(heap, (ng, v))
    return math.inf
