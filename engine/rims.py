"""The geometry of the exact planner's rims: clearance-inflated crater discs, the segments
tangent to two of them, and arcs along a rim driven as circumscribed polygons.

A robot drives polylines, so an arc is driven as a polygon circumscribed about the rim
(every edge tangent to it, so it never cuts into the crater) with a step of at most
`ARC_STEP` radians; its cost is that polyline's length, the distance the robot really drives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from engine.geometry import Point

Polyline = tuple[Point, ...]

ARC_STEP = math.radians(5.0)
"""Largest angle one polygon edge of a driven arc covers."""
COS_HALF = math.cos(ARC_STEP / 2.0)


@dataclass(frozen=True, slots=True)
class Rim:
    x: float
    y: float
    r: float  # the crater's radius inflated by the clearance (and a rounding margin)


class Arc(NamedTuple):
    """An arc edge, realized as a polyline only when a route uses it."""

    rim: Rim
    p: Point
    q: Point
    a0: float
    sweep: float
    reverse: bool  # driven from q back to p

    def polyline(self) -> Polyline:
        poly = arc_polyline(self.rim, self.p, self.q, self.a0, self.sweep)
        return tuple(reversed(poly)) if self.reverse else poly


def bitangents(
    xyr: npt.NDArray[np.float64], i: npt.NDArray[np.int64], j: npt.NDArray[np.int64]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
    """The segments tangent to discs i and j (arrays of pairs): two outer always, two inner if
    the discs are apart. Four blocks of len(i) rows (outer +, outer -, inner +, inner -): the
    ends on i, on j, and whether the segment exists."""
    x1, y1, r1 = xyr[i, 0], xyr[i, 1], xyr[i, 2]
    dx, dy = xyr[j, 0] - x1, xyr[j, 1] - y1
    d = np.hypot(dx, dy)
    apart = d > np.abs(r1 - xyr[j, 2])
    d = np.where(apart, d, 1.0)
    vx, vy = dx / d, dy / d
    ps, qs, oks = [], [], []
    for r2 in (xyr[j, 2], -xyr[j, 2]):  # outer, then inner
        c = (r1 - r2) / d
        ok = apart & (c * c <= 1.0)
        h = np.sqrt(np.maximum(0.0, 1.0 - c * c))
        for sign in (1.0, -1.0):
            nx, ny = vx * c - sign * h * vy, vy * c + sign * h * vx
            ps.append(np.stack([x1 + r1 * nx, y1 + r1 * ny], axis=1))
            qs.append(np.stack([xyr[j, 0] + r2 * nx, xyr[j, 1] + r2 * ny], axis=1))
            oks.append(ok)
    return np.concatenate(ps), np.concatenate(qs), np.concatenate(oks)


def arc_length(r: float, sweep: float) -> float:
    """Length of the circumscribed polygon `arc_polyline` drives for this sweep."""
    if sweep <= 1e-12:
        return 0.0
    n = max(1, math.ceil(sweep / ARC_STEP))
    return 2.0 * n * r * math.tan(sweep / n / 2.0)


def arc_polyline(c: Rim, p: Point, q: Point, a0: float, sweep: float) -> Polyline:
    """From p counter-clockwise by `sweep` to q, as a polygon circumscribed about the rim."""
    if sweep <= 1e-12:
        return (p, q)
    n = max(1, math.ceil(sweep / ARC_STEP))
    step = sweep / n
    outer = c.r / math.cos(step / 2.0)
    mids = tuple(
        (
            c.x + outer * math.cos(a0 + (k + 0.5) * step),
            c.y + outer * math.sin(a0 + (k + 0.5) * step),
        )
        for k in range(n)
    )
    return (p, *mids, q)
