"""Exact shortest paths among circular craters: the tangent (visibility) graph, searched by A*.

Craters are static discs, so a shortest path between two free points is made of straight
segments tangent to the (clearance-inflated) discs and arcs along their rims. The graph's
nodes are the tangent points of every pair of discs plus, per query, the tangents from the
start and the goal; its edges are the collision-free tangent segments and the free arcs
between angularly neighbouring nodes on one rim. A* with the straight-line heuristic finds the
shortest route.

The graph is built lazily, one rim at a time: a rim is opened (its bitangents tested, its
ring of nodes and arcs made) when A* first leaves a node on it, and stays open for the
world's later queries. A* only needs the edges of the nodes it leaves, so the route is the
one the whole graph gives, but a query on a big world opens only the rims near its route
(the whole graph has ~210,000 nodes at 600 craters). Segments are tested many at once on a
crater grid (engine/segment_grid.py).

Robots drive polylines, so an arc is driven as a polygon circumscribed about the rim (every
edge tangent to it, so it never cuts into the crater) with a step of at most `rims.ARC_STEP`
radians; the edge's cost is that polyline's length, the distance the robot really drives.
Its excess over the true arc is tan(δ/2)/(δ/2) − 1 ≈ 0.05 % for δ = 5°.

The planner answers from goal fields (engine/tangent_field.py): many robots price one goal,
so its side of the work is done once, over the whole graph as arrays
(engine/tangent_arrays.py); `TangentGraph.shortest` is one A* query (engine/tangent_query.py),
with the same lengths. One robot pricing many goals (Policy 3's excavator after each dig,
hundreds of waiting sites at scale 100) is the same thing the other way round: the graph is
symmetric, so the field of its start answers every goal, and the route found from the goal
is driven backwards (`_backwards`).

Nothing here is random: the same world and query always give the same path.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections import OrderedDict
from collections.abc import Callable
from typing import TypeVar

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree  # type: ignore[import-untyped]

from engine.geometry import Point, dist, segment_point_distance
from engine.planning import Path, PlanningError, ShortcutPlanner
from engine.rims import COS_HALF, Arc, Rim, arc_length, bitangents
from engine.segment_grid import SegmentGrid, grid_step
from engine.tangent_arrays import FlatGraph, StartFan
from engine.tangent_field import GoalField
from engine.tangent_query import Edge, Leg, Query
from engine.world import CLEARANCE, World

_FIELDS = 32
"""Recent goals whose distance fields a planner keeps, at least: an auction's bidders price
one goal at a time, a site waiting for an excavator is announced again and again, and a few
goals are open at once."""
_FIELD_BYTES = 104 * 2**20
"""More are kept while their arrays fit in this: 32 at 600 craters (3.2 MB each, where memory
is tight), 176 at 180 (0.6 MB). Policy 3 prices every open site from each excavator's new
place, more goals than 32: at scale 30 the fields it made again were a third of its time."""
_SWEEP = 2
"""Goals in a row, from one start, whose fields are not kept: from then on that start's own
field answers (a robot pricing many open tasks), until it asks a goal whose field is kept."""
_FANS = 1024
"""Recent starts whose fans a planner keeps (~0.1 MB each at 600 craters): an idle robot
prices every task it hears from where it stands (scale 100's first 1,000 simulated seconds:
87,230 solves from 1,649 starts to 896 goals)."""
_GROW = 1e-6
"""Rims are planned this much outside the inflated radius, so a tangent segment passes the
index's strict `distance > radius` test despite rounding."""


T = TypeVar("T")
XYR = tuple[float, float, float]


class TangentGraph:
    """The tangent graph of one world's craters: rims, their tangent nodes and free edges."""

    def __init__(self, world: World, clearance: float = CLEARANCE) -> None:
        self._world = world
        self._index = world.index
        self.rims = [
            Rim(c.x, c.y, c.r + clearance + _GROW + 1e-9 * (c.r + clearance)) for c in world.craters
        ]
        self._rim_xyr = np.array([(r.x, r.y, r.r) for r in self.rims]).reshape(-1, 3)
        self._rim_x, self._rim_y, self._rim_r = (self._rim_xyr[:, k].copy() for k in range(3))
        self._rim_r2 = self._rim_r * self._rim_r
        self._craters_xyr = np.array([(c.x, c.y, c.r + clearance) for c in world.craters]).reshape(
            -1, 3
        )
        self.points: list[Point] = []
        self.adj: list[list[Edge]] = []
        self.rim_of: list[int] = []
        # (angle, node) per rim, None until the rim is opened (`ring`)
        self.rings: list[list[tuple[float, int]] | None] = [None for _ in self.rims]
        self._grid = SegmentGrid(
            self._craters_xyr, grid_step(self._craters_xyr, world.width, world.height)
        )
        self._near_rim = self._craters_near_rims(world, clearance)
        self._clear_rim = [  # no crater near, the whole ring in the area: every arc is free
            not self._near_rim[i]
            and all(
                v - rim.r / COS_HALF >= 0.0 and v + rim.r / COS_HALF <= side
                for v, side in ((rim.x, world.width), (rim.y, world.height))
            )
            for i, rim in enumerate(self.rims)
        ]
        self._pending: list[list[int]] = [[] for _ in self.rims]  # nodes on unopened rims
        self.opened = 0

    def ring(self, i: int) -> list[tuple[float, int]]:
        """Rim i's nodes in angular order, joined by their free arcs; built the first time a
        route reaches the rim (A* looks at few rims, so a big world's graph is built only
        where routes go).

        Opening rim i tests its bitangents to every rim not opened yet (all at once on the
        crater grid) and makes a node at each end of a free one; its bitangents to rims opened
        before were tested then, and their nodes on i wait in `_pending[i]`."""
        ring = self.rings[i]
        if ring is not None:
            return ring
        self.opened += 1
        closed = np.array([j for j, r in enumerate(self.rings) if r is None and j != i], dtype=int)
        lo, hi = np.minimum(closed, i), np.maximum(closed, i)
        p, q, ok = bitangents(self._rim_xyr, lo, hi)
        ok &= self._in_area_all(p) & self._in_area_all(q)
        ok[ok] = self._grid.free(p[ok, 0], p[ok, 1], q[ok, 0], q[ok, 1])
        mine = self._pending[i]
        self._pending[i] = []
        los, his = np.tile(lo, 4).tolist(), np.tile(hi, 4).tolist()
        for k in np.flatnonzero(ok).tolist():
            a, b = self._node(los[k], p[k]), self._node(his[k], q[k])
            self._link(
                self.adj,
                a,
                b,
                (self.points[a], self.points[b]),
                dist(self.points[a], self.points[b]),
            )
            mine.append(a if los[k] == i else b)
            self._pending[his[k] if los[k] == i else los[k]].append(b if los[k] == i else a)
        ring = sorted((self._angle(i, self.points[n]), n) for n in mine)
        self.rings[i] = ring
        self._link_ring(self.adj, i, ring, lambda a, b: True)
        return ring

    def _node(self, rim: int, p: npt.NDArray[np.float64]) -> int:
        self.points.append((float(p[0]), float(p[1])))
        self.adj.append([])
        self.rim_of.append(rim)
        return len(self.points) - 1

    def _craters_near_rims(self, world: World, clearance: float) -> list[list[XYR]]:
        """Per rim, the craters an arc driven around it could touch (a k-d tree finds the
        candidate pairs; only these are checked when an arc is linked)."""
        out: list[list[XYR]] = [[] for _ in self.rims]
        if len(self.rims) < 2:
            return out
        reach = float(self._craters_xyr[:, 2].max() + self._rim_xyr[:, 2].max() / COS_HALF)
        tree = cKDTree(self._rim_xyr[:, :2])
        for i, k in sorted(tree.query_pairs(reach, output_type="ndarray").tolist()):
            for rim, other in ((i, k), (k, i)):
                c, own = world.craters[other], self.rims[rim]
                if math.hypot(c.x - own.x, c.y - own.y) < c.r + clearance + own.r / COS_HALF:
                    out[rim].append((c.x, c.y, c.r + clearance))
        for near in out:
            near.sort()
        return out

    def _in_area_all(self, p: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
        w, h = self._world.width, self._world.height
        return (p[:, 0] >= 0.0) & (p[:, 0] <= w) & (p[:, 1] >= 0.0) & (p[:, 1] <= h)

    def _angle(self, rim: int, p: Point) -> float:
        c = self.rims[rim]
        return math.atan2(p[1] - c.y, p[0] - c.x)

    @staticmethod
    def _link(
        adj: list[list[Edge]] | dict[int, list[Edge]],
        a: int,
        b: int,
        leg: Leg,
        cost: float,
    ) -> None:
        back: Leg = (
            Arc(leg.rim, leg.p, leg.q, leg.a0, leg.sweep, True)
            if isinstance(leg, Arc)
            else (leg[1], leg[0])
        )
        (adj[a] if isinstance(adj, list) else adj.setdefault(a, [])).append((b, cost, leg))
        (adj[b] if isinstance(adj, list) else adj.setdefault(b, [])).append((a, cost, back))

    def _link_ring(
        self,
        adj: list[list[Edge]] | dict[int, list[Edge]],
        rim: int,
        ring: list[tuple[float, int]],
        wanted: Callable[[int, int], bool],
        where: Callable[[int], Point] | None = None,
    ) -> None:
        """Arc edges between angular neighbours on one rim (counter-clockwise a → b)."""
        if len(ring) < 2:
            return
        at = where or self.points.__getitem__
        for k, (a0, a) in enumerate(ring):
            a1, b = ring[(k + 1) % len(ring)]
            if not wanted(a, b):
                continue
            arc = Arc(self.rims[rim], at(a), at(b), a0, (a1 - a0) % (2.0 * math.pi), False)
            if self._arc_free(rim, arc):
                self._link(adj, a, b, arc, arc_length(arc.rim.r, arc.sweep))

    def _arc_free(self, rim: int, arc: Arc) -> bool:
        """A driven arc stays in the area and clear of the craters near its rim."""
        if self._clear_rim[rim]:
            return True
        poly = arc.polyline()
        if not all(self._in_area(p) for p in poly):
            return False
        return all(
            segment_point_distance(poly[j], poly[j + 1], (cx, cy)) > r
            for cx, cy, r in self._near_rim[rim]
            for j in range(len(poly) - 1)
        )

    def tangents(self, p: Point) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
        """The points where p's tangents touch every rim, untested: row i and row i + n (n
        rims) are on rim i; `exists` is False where p is inside the rim or the point outside
        the area. Testing which segments are free is left to the rims a search reaches."""
        cx, cy, r = self._rim_x, self._rim_y, self._rim_r
        dx, dy = p[0] - cx, p[1] - cy
        d2 = dx * dx + dy * dy
        outside = d2 > self._rim_r2
        # the tangent points: c + (r²/d²)·v ± (r·√(d² − r²)/d²)·v⊥, with v = p − c
        k = np.where(outside, self._rim_r2 / np.where(outside, d2, 1.0), 0.0)
        h = np.where(outside, r * np.sqrt(np.maximum(d2 - self._rim_r2, 0.0)), 0.0) / np.where(
            outside, d2, 1.0
        )
        bx, by = cx + k * dx, cy + k * dy
        tx = np.concatenate([bx - h * dy, bx + h * dy])
        ty = np.concatenate([by + h * dx, by - h * dx])
        exists = np.concatenate([outside, outside])
        exists &= (tx >= 0.0) & (tx <= self._world.width) & (ty >= 0.0) & (ty <= self._world.height)
        return np.stack([tx, ty], axis=1), exists

    def free_from(self, p: Point, ends: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
        """Which segments from p to these few points no crater blocks."""
        return self._grid.free_few(
            np.full(len(ends), p[0]), np.full(len(ends), p[1]), ends[:, 0], ends[:, 1]
        )

    def _link_temps(
        self,
        extra: dict[int, list[Edge]],
        rim: int,
        temps: list[tuple[float, int]],
        where: Callable[[int], Point],
    ) -> None:
        """Arcs from a query's tangent points on one rim to their angular neighbours: the
        nearest fixed node either way round (found by bisection) and each other."""
        ring = self.ring(rim)
        near = set(temps)
        for angle, _ in temps:
            if ring:
                k = bisect_left(ring, (angle, -(2**62)))
                near.add(ring[k % len(ring)])
                near.add(ring[k - 1])
        self._link_ring(extra, rim, sorted(near), lambda a, b: a < 0 or b < 0, where)

    def _in_area(self, p: Point) -> bool:
        return 0.0 <= p[0] <= self._world.width and 0.0 <= p[1] <= self._world.height

    def shortest(self, start: Point, goal: Point) -> Path:
        """The shortest collision-free path from start to goal (A* over the tangent graph,
        joined by the start's and the goal's tangents to the rims they see)."""
        if self._index.segment_free(start, goal):
            return (start, goal)
        return polyline(start, goal, Query(self, start, goal).search())


def polyline(start: Point, goal: Point, route: list[Leg] | None) -> Path:
    """The path a robot drives along a route's legs."""
    if route is None:
        raise PlanningError(f"no path from {start} to {goal}")
    out: list[Point] = [start]
    for leg in route:
        out.extend((leg.polyline() if isinstance(leg, Arc) else leg)[1:])
    return tuple(out)


class TangentPlanner(ShortcutPlanner):
    """The `exact` planner: shortest paths over the world's tangent graph, answered from the
    goal's distance field (engine/tangent_field.py): the many robots that price one task
    share its goal's side of the work. The fields of the last goals are kept (`_FIELDS`,
    `_FIELD_BYTES`)."""

    cache_limit = 16_384
    """Solved paths kept: an exact answer is the same whenever it is asked, so one forgotten
    is found again (most repeats come within a few thousand queries; at scale 100 keeping
    them all was a quarter of a GB)."""

    def __init__(self, world: World) -> None:
        super().__init__(world)
        self._world = world
        self._graph: TangentGraph | None = None
        self._flat: FlatGraph | None = None
        self._fields: OrderedDict[Point, GoalField] = OrderedDict()
        self._fields_kept = _FIELDS  # set with the graph's size (`flat`)
        self._fans: OrderedDict[Point, StartFan] = OrderedDict()
        self._sweep: tuple[Point | None, int] = (None, 0)  # a start, its goals not kept in a row

    @property
    def graph(self) -> TangentGraph:
        if self._graph is None:  # built at the first blocked query: open maps never pay
            self._graph = TangentGraph(self._world)
        return self._graph

    @property
    def flat(self) -> FlatGraph:
        if self._flat is None:  # the whole graph, opened at the first blocked query
            self._flat = FlatGraph(self.graph)
            # the fields `_FIELD_BYTES` holds (`dist`, `pred`: 16 bytes a node); `_FIELDS` at least
            self._fields_kept = max(_FIELDS, _FIELD_BYTES // (16 * (self._flat.goal + 1)))
        return self._flat

    def field(self, goal: Point) -> GoalField:
        """The goal's distance field, kept or made."""
        flat = self.flat
        return _recent(
            self._fields, goal, self._fields_kept, lambda: GoalField(self.graph, flat, goal)
        )

    def fan(self, start: Point) -> StartFan:
        """The start's fan, kept or made."""
        return _recent(self._fans, start, _FANS, lambda: StartFan(self.graph, self.flat, start))

    def _solve(self, start: Point, goal: Point) -> Path:
        # plan() answered a free straight segment already
        if self._sweeping(start, goal):
            back = self.field(start).route(self.fan(goal), direct_blocked=True)
            return polyline(start, goal, None if back is None else _backwards(back))
        route = self.field(goal).route(self.fan(start), direct_blocked=True)
        return polyline(start, goal, route)

    def _sweeping(self, start: Point, goal: Point) -> bool:
        """Is this start pricing goal after goal whose fields are not kept (`_SWEEP` in a
        row)? Then its own field answers: one Dijkstra instead of one per goal, and the fields
        other robots share are not pushed out."""
        if goal in self._fields:
            self._sweep = (None, 0)
            return False
        last, missed = self._sweep
        missed = missed + 1 if last == start else 1
        self._sweep = (start, missed)
        return missed >= _SWEEP

    def close(self) -> None:
        self._graph = None
        self._flat = None
        self._fields.clear()
        self._fans.clear()
        self._sweep = (None, 0)


def _backwards(route: list[Leg]) -> list[Leg]:
    """A route driven the other way: the same points, so the same polyline reversed. The
    graph keeps each edge both ways as exact reversals (`TangentGraph._link`), and a
    field's ends and a fan's tangent points are the same numbers, so this is the route the
    goal's field gives, leg for leg (tests/engine/test_tangent_field.py)."""
    return [
        Arc(leg.rim, leg.p, leg.q, leg.a0, leg.sweep, not leg.reverse)
        if isinstance(leg, Arc)
        else (leg[1], leg[0])
        for leg in reversed(route)
    ]


def _recent(kept: OrderedDict[Point, T], key: Point, most: int, make: Callable[[], T]) -> T:
    """An LRU look-up: the kept value, or a new one (the least recent dropped past `most`)."""
    value = kept.get(key)
    if value is not None:
        kept.move_to_end(key)
        return value
    value = kept[key] = make()
    if len(kept) > most:
        kept.popitem(last=False)
    return value
