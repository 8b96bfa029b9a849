"""One exact-planner query on the tangent graph (engine/tangent_planner.py): the start and goal
joined to the rims by tangents found lazily, and the A* search over the whole.

Split from the graph because it is the per-query half: the graph is built once per world and
kept, a query's nodes and edges live only as long as its search.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from typing import Protocol

import numpy as np
import numpy.typing as npt

from engine.geometry import Point, dist
from engine.planning import Path
from engine.rims import Arc, Rim
from engine.segment_grid import SegmentGrid
from engine.world import World

Leg = Path | Arc
Edge = tuple[int, float, Leg]  # (to node, cost, the leg driven from the edge's start)


class TangentGraph(Protocol):
    """What a query, a goal's field and the flat arrays read of the world's tangent graph
    (`engine.tangent_planner.TangentGraph`, which grows as rims are opened)."""

    @property
    def rims(self) -> list[Rim]: ...
    @property
    def points(self) -> list[Point]: ...
    @property
    def adj(self) -> list[list[Edge]]: ...
    @property
    def rim_of(self) -> list[int]: ...
    @property
    def rings(self) -> list[list[tuple[float, int]] | None]: ...
    @property
    def _world(self) -> World: ...
    @property
    def _grid(self) -> SegmentGrid: ...
    @property
    def _rim_x(self) -> npt.NDArray[np.float64]: ...
    @property
    def _rim_y(self) -> npt.NDArray[np.float64]: ...
    @property
    def _rim_r(self) -> npt.NDArray[np.float64]: ...

    def ring(self, i: int) -> list[tuple[float, int]]: ...
    def tangents(self, p: Point) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]: ...
    def free_from(self, p: Point, ends: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]: ...
    def _angle(self, rim: int, p: Point) -> float: ...
    def _arc_free(self, rim: int, arc: Arc) -> bool: ...
    def _link_temps(
        self,
        extra: dict[int, list[Edge]],
        rim: int,
        temps: list[tuple[float, int]],
        where: Callable[[int], Point],
    ) -> None: ...
    @staticmethod
    def _link(
        adj: list[list[Edge]] | dict[int, list[Edge]],
        a: int,
        b: int,
        leg: Leg,
        cost: float,
    ) -> None: ...


_SOURCE, _TARGET = -1, -2
"""A query's start and goal nodes; its tangent points get the negative ids after them (the
world's graph, whose ids are non-negative, grows while the query runs)."""
_FEED = 16
"""Start tangents tested together when the search takes the next one."""


class Query:
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
