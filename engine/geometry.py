"""Plane geometry on points, segments and circles: the exact tests the planner relies on."""

from __future__ import annotations

import math
from collections.abc import Sequence

Point = tuple[float, float]


def dist(a: Point, b: Point) -> float:
    return math.hypot(b[0] - a[0], b[1] - a[1])


def path_length(path: Sequence[Point]) -> float:
    return sum(dist(path[i], path[i + 1]) for i in range(len(path) - 1))


def segment_point_distance(a: Point, b: Point, p: Point) -> float:
    """Shortest distance from point p to the segment a–b."""
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    seg2 = dx * dx + dy * dy
    if seg2 == 0.0:
        return math.hypot(p[0] - ax, p[1] - ay)
    u = ((p[0] - ax) * dx + (p[1] - ay) * dy) / seg2
    u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
    return math.hypot(ax + u * dx - p[0], ay + u * dy - p[1])


def first_entry(a: Point, b: Point, c: Point, r: float) -> float | None:
    """Fraction u in [0, 1] of a–b where it first comes within r of c, or None if it never does."""
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    fx, fy = ax - c[0], ay - c[1]
    cc = fx * fx + fy * fy - r * r
    if cc <= 0.0:
        return 0.0
    aa = dx * dx + dy * dy
    if aa == 0.0:
        return None
    bb = 2.0 * (fx * dx + fy * dy)
    disc = bb * bb - 4.0 * aa * cc
    if disc < 0.0:
        return None
    u = (-bb - math.sqrt(disc)) / (2.0 * aa)
    return u if 0.0 <= u <= 1.0 else None


def point_along(path: Sequence[Point], d: float) -> tuple[Point, float]:
    """The point at distance d along a polyline, and the heading (radians) there."""
    heading = 0.0
    for i in range(len(path) - 1):
        a, b = path[i], path[i + 1]
        seg = dist(a, b)
        if seg > 0.0:
            heading = math.atan2(b[1] - a[1], b[0] - a[0])
        if d <= seg or i == len(path) - 2:
            u = 0.0 if seg == 0.0 else min(1.0, max(0.0, d / seg))
            return (a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])), heading
        d -= seg
    return path[-1], heading


def remaining_path(path: Sequence[Point], d: float) -> list[Point]:
    """The rest of a polyline after distance d: the current point, then the vertices ahead."""
    pos, _ = point_along(path, d)
    out = [pos]
    for i in range(len(path) - 1):
        seg = dist(path[i], path[i + 1])
        if d < seg:
            out.extend(path[i + 1 :])
            return out
        d -= seg
    return out
