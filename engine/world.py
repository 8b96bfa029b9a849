"""The physical world of one run, generated from the scenario and the seed."""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

import numpy as np

from engine.geometry import Point
from engine.scenario import Crater, Scenario, ScenarioError

CLEARANCE = 0.5
"""Robots keep this far from a crater's rim (their half-width); planning inflates craters by it."""


class CraterIndex:
    """Craters bucketed on a coarse grid, so segment tests look only at nearby craters."""

    def __init__(
        self, craters: tuple[Crater, ...], margin: float = CLEARANCE, bucket: float = 20.0
    ) -> None:
        self.bucket = bucket
        self.buckets: dict[tuple[int, int], list[tuple[float, float, float]]] = defaultdict(list)
        for c in craters:
            r = c.r + margin
            for bx in range(int((c.x - r) // bucket), int((c.x + r) // bucket) + 1):
                for by in range(int((c.y - r) // bucket), int((c.y + r) // bucket) + 1):
                    self.buckets[(bx, by)].append((c.x, c.y, r))

    def _cells(
        self, x0: float, y0: float, x1: float, y1: float, c0: int, c1: int, r0: int, r1: int
    ) -> Iterator[list[tuple[float, float, float]]]:
        """The buckets a segment passes through that hold craters (a crater may be in
        several), given the columns and rows of its ends. Column by column, the rows the
        segment spans there (padded by one bucket-hundredth against rounding): the cost grows
        with the segment's length, not with its bounding box's area."""
        b = self.bucket
        get = self.buckets.get
        if x0 > x1:
            x0, y0, x1, y1, c0, c1 = x1, y1, x0, y0, c1, c0
        if r0 > r1:
            r0, r1 = r1, r0
        if (c1 - c0) * (r1 - r0) <= 4:  # a small box: every bucket of it is cheaper
            for bx in range(c0, c1 + 1):
                for by in range(r0, r1 + 1):
                    cell = get((bx, by))
                    if cell:
                        yield cell
            return
        dx, dy = x1 - x0, y1 - y0
        pad = b / 100.0
        for bx in range(c0, c1 + 1):
            if dx > 0.0:
                ta = min(1.0, max(0.0, (bx * b - x0) / dx))
                tb = min(1.0, max(0.0, ((bx + 1) * b - x0) / dx))
                ya, yb = y0 + ta * dy, y0 + tb * dy
            else:
                ya, yb = y0, y1
            if ya > yb:
                ya, yb = yb, ya
            for by in range(int((ya - pad) // b), int((yb + pad) // b) + 1):
                cell = get((bx, by))
                if cell:
                    yield cell

    def point_free(self, x: float, y: float) -> bool:
        b = self.bucket
        hypot = math.hypot
        for cx, cy, r in self.buckets.get((int(x // b), int(y // b)), ()):
            if not hypot(x - cx, y - cy) > r:
                return False
        return True

    def segment_free(self, a: Point, b: Point) -> bool:
        """No crater (with its margin) within reach of the segment: the first one found
        answers. A segment within one bucket reads that bucket alone (longer ones walk the
        buckets, `_cells`), and `segment_point_distance`'s arithmetic is inlined: the planner
        asks this hundreds of thousands of times a mission."""
        ax, ay = a
        bx, by = b
        dx, dy = bx - ax, by - ay
        seg2 = dx * dx + dy * dy
        if seg2 == 0.0:
            return self.point_free(ax, ay)
        hypot = math.hypot
        size = self.bucket
        c0, c1, r0, r1 = int(ax // size), int(bx // size), int(ay // size), int(by // size)
        if c0 == c1 and r0 == r1:  # one bucket: a third of all segments
            cell = self.buckets.get((c0, r0))
            if cell is None:
                return True
            cells: Iterable[list[tuple[float, float, float]]] = (cell,)
        else:
            cells = self._cells(ax, ay, bx, by, c0, c1, r0, r1)
        for cell in cells:
            for cx, cy, r in cell:
                u = ((cx - ax) * dx + (cy - ay) * dy) / seg2
                u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
                if not hypot(ax + u * dx - cx, ay + u * dy - cy) > r:
                    return False
        return True


@dataclass(frozen=True, slots=True)
class Site:
    """A resource site: ground truth the robots must discover."""

    id: str
    x: float
    y: float
    minerals: int


@dataclass(frozen=True, slots=True)
class SearchGrid:
    """Cells small enough that a scout at a cell's waypoint scans the whole cell."""

    cols: int
    rows: int
    cell_w: float
    cell_h: float
    waypoints: tuple[Point | None, ...]  # row-major; None where the cell is all crater

    def cell_of(self, x: float, y: float) -> int:
        c = min(self.cols - 1, max(0, int(x / self.cell_w)))
        r = min(self.rows - 1, max(0, int(y / self.cell_h)))
        return r * self.cols + c

    def centre(self, cell: int) -> Point:
        r, c = divmod(cell, self.cols)
        return ((c + 0.5) * self.cell_w, (r + 0.5) * self.cell_h)


@dataclass(frozen=True, slots=True)
class World:
    width: float
    height: float
    plant: Point
    craters: tuple[Crater, ...]
    sites: tuple[Site, ...]
    grid: SearchGrid
    index: CraterIndex = field(compare=False)

    def is_free(self, x: float, y: float) -> bool:
        """Inside the area and clear of every crater by the robots' clearance."""
        if not (0.0 <= x <= self.width and 0.0 <= y <= self.height):
            return False
        return self.index.point_free(x, y)

    def to_dict(self) -> dict[str, object]:
        """The static map, as viewers draw it."""
        return {
            "width": self.width,
            "height": self.height,
            "plant": {"x": self.plant[0], "y": self.plant[1]},
            "obstacles": [{"x": c.x, "y": c.y, "r": c.r} for c in self.craters],
            "grid": {
                "cols": self.grid.cols,
                "rows": self.grid.rows,
                "cell_w": self.grid.cell_w,
                "cell_h": self.grid.cell_h,
            },
            "sites": [{"id": s.id, "x": s.x, "y": s.y, "minerals": s.minerals} for s in self.sites],
        }


def _free(x: float, y: float, s: Scenario, wide: CraterIndex) -> bool:
    edge = 0.1
    if not (edge <= x <= s.width - edge and edge <= y <= s.height - edge):
        return False
    return wide.point_free(x, y)


def _waypoint(
    cx: float, cy: float, cw: float, ch: float, s: Scenario, wide: CraterIndex
) -> Point | None:
    """The cell's centre, or the free point of the cell nearest to it (None: all crater)."""
    if _free(cx, cy, s, wide):
        return (cx, cy)
    steps = 8
    candidates = [
        (cx + cw * (i / steps - 0.5), cy + ch * (j / steps - 0.5))
        for i in range(steps + 1)
        for j in range(steps + 1)
    ]
    candidates.sort(key=lambda p: (math.hypot(p[0] - cx, p[1] - cy), p))
    for p in candidates:
        if _free(p[0], p[1], s, wide):
            return p
    return None


def make_grid(s: Scenario, craters: tuple[Crater, ...]) -> SearchGrid:
    side = s.scan_radius * math.sqrt(2.0)  # a square this wide fits in the scan circle
    cols, rows = math.ceil(s.width / side - 1e-9), math.ceil(s.height / side - 1e-9)
    cw, ch = s.width / cols, s.height / rows
    wide = CraterIndex(craters, margin=2 * CLEARANCE)  # scan points keep a double margin
    wps: list[Point | None] = []
    for r in range(rows):
        for c in range(cols):
            wps.append(_waypoint((c + 0.5) * cw, (r + 0.5) * ch, cw, ch, s, wide))
    return SearchGrid(cols, rows, cw, ch, tuple(wps))


def _random_craters(s: Scenario, rng: np.random.Generator) -> list[Crater]:
    px, py = s.plant_xy
    lo, hi = s.crater_radius
    out: list[Crater] = []
    for _ in range(s.random_craters * 50):
        if len(out) == s.random_craters:
            break
        r = float(rng.uniform(lo, hi))
        x = float(rng.uniform(0.0, s.width))
        y = float(rng.uniform(0.0, s.height))
        if math.hypot(x - px, y - py) > r + s.start_spread + 4.0:
            out.append(Crater(x=round(x, 3), y=round(y, 3), r=round(r, 3)))
    return out


def generate_world(s: Scenario, rng: np.random.Generator) -> World:
    """Craters, then sites where the search can find them, then minerals split over sites."""
    craters = tuple(list(s.craters) + _random_craters(s, rng))
    grid = make_grid(s, craters)
    wide = CraterIndex(craters, margin=2 * CLEARANCE)
    px, py = s.plant_xy
    edge = min(1.0, s.width / 4, s.height / 4)
    points: list[Point] = []
    attempts = 0
    while len(points) < s.sites:
        attempts += 1
        if attempts > 200 * s.sites + 1000:
            raise ScenarioError(
                "sites: could not place every site in free space away from the start area "
                "(fewer sites, fewer or smaller craters, or a smaller start_spread)"
            )
        x = float(rng.uniform(edge, s.width - edge))
        y = float(rng.uniform(edge, s.height - edge))
        if math.hypot(x - px, y - py) < s.start_spread + 2.0:
            continue
        if not wide.point_free(x, y):
            continue
        wp = grid.waypoints[grid.cell_of(x, y)]
        if wp is None or math.hypot(x - wp[0], y - wp[1]) > s.scan_radius * 0.999:
            continue  # the scan point of its cell (moved out of a crater) would not see it
        if any(math.hypot(x - q[0], y - q[1]) < s.scan_radius for q in points):
            continue
        points.append((round(x, 3), round(y, 3)))
    counts = 1 + rng.multinomial(s.minerals - s.sites, [1.0 / s.sites] * s.sites)
    sites = tuple(
        Site(id=f"site-{i + 1}", x=p[0], y=p[1], minerals=int(n))
        for i, (p, n) in enumerate(zip(points, counts, strict=True))
    )
    return World(s.width, s.height, (px, py), craters, sites, grid, CraterIndex(craters))
