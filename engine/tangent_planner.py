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

Nothing here is random: the same world and query always give the same path.
"""

from __future__ import annotations

import heapq
import math
from bisect import bisect_left
from collections.abc import Callable

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree  # type: ignore[import-untyped]

from engine.geometry import Point, dist, segment_point_distance
from engine.planning import Path, PlanningError, ShortcutPlanner
from engine.rims import COS_HALF, Arc, Rim, arc_length, bitangents
from engine.segment_grid import SegmentGrid, grid_step
from engine.world import CLEARANCE, World

_GROW = 1e-6
"""Rims are planned this much outside the inflated radius, so a tangent segment passes the
index's strict `distance > radius` test despite rounding."""


XYR = tuple[float, float, float]
Leg = Path | Arc
Edge = tuple[int, float, Leg]  # (to node, cost, the leg driven from the edge's start)


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
        route = _Query(self, start, goal).search()
        if route is None:
            raise PlanningError(f"no path from {start} to {goal}")
        out: list[Point] = [start]
        for leg in route:
            out.extend((leg.polyline() if isinstance(leg, Arc) else leg)[1:])
        return tuple(out)


_SOURCE, _TARGET = -1, -2
"""A query's start and goal nodes; its tangent points get the negative ids after them (the
world's graph, whose ids are non-negative, grows while the query runs)."""
_FEED = 16
"""Start tangents tested together when the search takes the next one."""


class _Query:
    """One query's part of the graph: its start and goal, joined by their tangents to every rim
    they see, found lazily. Each has ~2 tangents per rim (1,200 at 600 craters), and testing
    them all dominated a query at scale; a shortest route touches few. So the goal's tangents
    on a rim are tested when the search reaches the rim, and the start's tangents are fed to
    the search in order of their A* key (length to the tangent point plus straight on to the
    goal): one is tested only when its key comes up, so the search, and its route, are those
    of the graph with every free tangent in it."""

    def __init__(self, graph: TangentGraph, start: Point, goal: Point) -> None:
        self.graph, self.start, self.goal = graph, start, goal
        self.points: dict[int, Point] = {_SOURCE: start, _TARGET: goal}
        self.rim_of: dict[int, int] = {}
        self.extra: dict[int, list[Edge]] = {}
        self.linked: set[int] = set()
        self.n = len(graph.rims)
        self.starts, self.starts_exist = graph.tangents(start)
        self.ends, self.ends_exist = graph.tangents(goal)
        # the start's tangent points, best key first; tested _FEED at a time as they come up
        rows = np.flatnonzero(self.starts_exist)
        pts = self.starts[rows]
        near = np.hypot(pts[:, 0] - start[0], pts[:, 1] - start[1])
        key = near + np.hypot(goal[0] - pts[:, 0], goal[1] - pts[:, 1])
        order = np.argsort(key, kind="stable")
        self.feed_rows: list[int] = rows[order].tolist()
        self.feed_key: list[float] = key[order].tolist()
        self.feed_g: list[float] = near[order].tolist()
        self.start_free: dict[int, bool] = {}  # row -> its segment from the start is free
        self.start_node: dict[int, int] = {}  # row -> its node, once its rim is linked

    def where(self, n: int) -> Point:
        return self.points[n] if n < 0 else self.graph.points[n]

    def _test_starts(self, rows: list[int]) -> None:
        rows = [r for r in rows if r not in self.start_free]
        if rows:
            free = self.graph.free_from(self.start, self.starts[rows]).tolist()
            self.start_free.update(zip(rows, free, strict=True))

    def reach(self, rim: int) -> None:
        """Before the search leaves a node on `rim`: its ring exists, and the query's free
        tangent points on it, joined to the start or goal and to their ring neighbours."""
        if rim < 0 or rim in self.linked:
            return
        self.linked.add(rim)
        graph = self.graph
        graph.ring(rim)
        mine = [rim, rim + self.n]
        self._test_starts([r for r in mine if self.starts_exist[r]])
        temps: list[tuple[float, int]] = []
        for r in mine:
            if self.start_free.get(r, False):
                self.start_node[r] = self._temp(rim, self.starts[r], _SOURCE, self.start, temps)
        ends = [r for r in mine if self.ends_exist[r]]
        if ends:
            for r, ok in zip(
                ends, graph.free_from(self.goal, self.ends[ends]).tolist(), strict=True
            ):
                if ok:
                    self._temp(rim, self.ends[r], _TARGET, self.goal, temps)
        if temps:
            graph._link_temps(self.extra, rim, temps, self.where)

    def _temp(
        self,
        rim: int,
        xy: npt.NDArray[np.float64],
        end: int,
        at: Point,
        temps: list[tuple[float, int]],
    ) -> int:
        t = (float(xy[0]), float(xy[1]))
        tn = -1 - len(self.points)
        self.points[tn] = t
        self.rim_of[tn] = rim
        self.graph._link(self.extra, end, tn, (at, t), dist(at, t))
        temps.append((self.graph._angle(rim, t), tn))
        return tn

    def search(self) -> list[Leg] | None:
        """A*; the legs of the shortest route, in order (None if there is none). Heap entries
        are (key, g, node, feed position); the start's tangents enter one at a time, through
        an entry for the next of them (node _SOURCE, its position in the feed)."""
        goal, graph, extra = self.goal, self.graph, self.extra
        best: dict[int, float] = {_SOURCE: 0.0}
        came: dict[int, tuple[int, Leg]] = {}
        heap: list[tuple[float, float, int, int]] = []
        if self.feed_rows:
            heap.append((self.feed_key[0], self.feed_g[0], _SOURCE, 0))
        while heap:
            _, g, u, pos = heapq.heappop(heap)
            if pos >= 0:
                self._feed(heap, pos, best, came)
                continue
            if u == _TARGET:
                route: list[Leg] = []
                while u in came:
                    u, leg = came[u]
                    route.append(leg)
                return route[::-1]
            if g > best.get(u, math.inf):
                continue
            self.reach(self.rim_of.get(u, -1) if u < 0 else graph.rim_of[u])
            edges = extra.get(u, [])
            if u >= 0:
                edges = graph.adj[u] + edges
            for v, w, leg in edges:
                if v == _SOURCE:
                    continue
                ng = g + w
                if ng < best.get(v, math.inf):
                    best[v] = ng
                    came[v] = (u, leg)
                    heapq.heappush(heap, (ng + dist(self.where(v), goal), ng, v, -1))
        return None

    def _feed(
        self,
        heap: list[tuple[float, float, int, int]],
        pos: int,
        best: dict[int, float],
        came: dict[int, tuple[int, Leg]],
    ) -> None:
        """The start's tangent at `pos` comes up: queue the next, and if this one's segment
        is free, relax the edge from the start to it (its rim linked first)."""
        rows = self.feed_rows
        if pos + 1 < len(rows):
            heapq.heappush(heap, (self.feed_key[pos + 1], self.feed_g[pos + 1], _SOURCE, pos + 1))
        row = rows[pos]
        if row not in self.start_free:
            self._test_starts(rows[pos : pos + _FEED])
        if not self.start_free[row]:
            return
        self.reach(row % self.n)
        v, g = self.start_node[row], self.feed_g[pos]
        if g < best.get(v, math.inf):
            best[v] = g
            came[v] = (_SOURCE, (self.start, self.points[v]))
            heapq.heappush(heap, (self.feed_key[pos], g, v, -1))


class TangentPlanner(ShortcutPlanner):
    """The `exact` planner: shortest paths over the world's tangent graph."""

    def __init__(self, world: World) -> None:
        super().__init__(world)
        self._world = world
        self._graph: TangentGraph | None = None

    @property
    def graph(self) -> TangentGraph:
        if self._graph is None:  # built at the first blocked query: open maps never pay
            self._graph = TangentGraph(self._world)
        return self._graph

    def _solve(self, start: Point, goal: Point) -> Path:
        return self.graph.shortest(start, goal)

    def close(self) -> None:
        self._graph = None
