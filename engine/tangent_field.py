"""One goal's exact distance field over the tangent graph (engine/tangent_planner.py), answering
the many starts that price the same goal.

In an auction every idle capable robot prices the same task location: at scale 100 some 400
start → goal queries share each goal, and an A* query each (engine/tangent_query.py) redid
the goal's side of the work 400 times. Here the goal's side is done once: a reverse Dijkstra
(scipy's, in C) from the goal's free tangents over the whole graph gives every node's exact
remaining distance, and a start is answered by its own tangents alone: it leaves by a free
tangent t on some rim, runs along that rim to t's nearest node either way round, and from there
the field says the rest. Each such option's length |s − t| + arc + field(node) is exact, so the
options are tried in order of it and the first whose segment and arc are free is the shortest
route. Where the start's or goal's two tangents on one rim lie between the same two nodes, the
route that runs past the other one is never shorter than the one that leaves by it (the two
tangents from a point to a circle have one length), so the graph's answer is this one's.

The field is computed out to a distance limit that grows (doubling) when a start needs more;
a node beyond it reads inf, so an option through it is known to be longer than
(limit + the start's shortest tangent), and a shorter option found first settles the query.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix  # type: ignore[import-untyped]
from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

from engine.geometry import Point, dist
from engine.rims import ARC_STEP, Arc, arc_length

if TYPE_CHECKING:
    from engine.tangent_planner import Leg, TangentGraph

Ints = npt.NDArray[np.int64]
Floats = npt.NDArray[np.float64]

_SLOTS_PER_RIM = 4
"""The goal's row in the matrix: two tangents per rim, each joined to a node either way."""
_FEED = 4
"""Start tangents whose segments are tested together (the first is most often the one)."""
_PRICED = 24
"""A start's tangent points priced first (then 4× as many, as long as one might be shorter)."""
_TAU = 2.0 * math.pi


def _key(rim: Any, angle: Any) -> Any:
    """A rim's nodes sort by angle after those of the rims before it."""
    return rim * 8.0 + (angle + math.pi)


def arc_lengths(r: Floats, sweep: Floats) -> Floats:
    """`rims.arc_length` for many arcs at once."""
    n = np.maximum(1.0, np.ceil(sweep / ARC_STEP))
    return np.where(sweep <= 1e-12, 0.0, 2.0 * n * r * np.tan(sweep / n / 2.0))


class FlatGraph:
    """The whole tangent graph (every rim opened) as arrays: a CSR matrix for Dijkstra, with one
    spare row (node `goal`) that each field fills with its goal's edges, and every rim's nodes
    sorted by (rim, angle) to find a point's neighbours on its rim by bisection."""

    def __init__(self, graph: TangentGraph) -> None:
        for i in range(len(graph.rims)):
            graph.ring(i)
        n = len(graph.points)
        self.goal = n
        src = np.repeat(np.arange(n), [len(a) for a in graph.adj])
        dst = np.fromiter((v for a in graph.adj for v, _, _ in a), np.int64, len(src))
        cost = np.fromiter((c for a in graph.adj for _, c, _ in a), np.float64, len(src))
        order = np.lexsort((cost, dst, src))  # one edge per pair of nodes: the shortest
        src, dst, cost = src[order], dst[order], cost[order]
        first = np.ones(len(src), dtype=bool)
        first[1:] = (src[1:] != src[:-1]) | (dst[1:] != dst[:-1])
        src, dst, cost = src[first], dst[first], cost[first]
        self.slots = _SLOTS_PER_RIM * len(graph.rims)
        indptr = np.zeros(n + 2, dtype=np.int64)
        indptr[1 : n + 1] = np.cumsum(np.bincount(src, minlength=n))
        indptr[n + 1] = indptr[n] + self.slots
        self.row = int(indptr[n])  # where the goal's row starts
        indices = np.concatenate([dst, np.full(self.slots, n)])
        data = np.concatenate([cost, np.zeros(self.slots)])
        self.matrix = csr_matrix((data, indices, indptr), shape=(n + 1, n + 1))
        rims = [(i, a, v) for i, ring in enumerate(graph.rings) if ring for a, v in ring]
        # sorted (rounding keeps the order of angles, and may only tie two; `neighbours`)
        self.ring_key = np.array([_key(i, a) for i, a, _ in rims], dtype=np.float64)
        # one more entry at the end, read (and ignored) where a rim has no node
        self.ring_angle = np.array([a for _, a, _ in rims] + [0.0], dtype=np.float64)
        self.ring_node = np.array([v for _, _, v in rims] + [n], dtype=np.int64)
        sizes = np.array([len(r) if r else 0 for r in graph.rings], dtype=np.int64)
        self.rim_hi = np.cumsum(sizes)
        self.rim_lo = self.rim_hi - sizes

    def set_goal_row(self, targets: Ints, costs: Floats) -> None:
        """The goal's edges (the rest of its row: self-loops, which Dijkstra ignores)."""
        lo, k = self.row, len(targets)
        self.matrix.indices[lo : lo + self.slots] = self.goal
        self.matrix.data[lo : lo + self.slots] = 0.0
        self.matrix.indices[lo : lo + k] = targets
        self.matrix.data[lo : lo + k] = costs

    def neighbours(self, rim: Ints, angle: Floats) -> tuple[Ints, Ints, Floats, Floats]:
        """For points at these angles on these rims: the index (in the ring arrays) of the
        nearest node counter-clockwise and clockwise (-1 on an empty rim), and the sweeps."""
        lo, hi = self.rim_lo[rim], self.rim_hi[rim]
        pos = np.searchsorted(self.ring_key, _key(rim, angle))
        while True:  # past nodes whose key ties the point's but whose angle is smaller
            behind = (pos < hi) & (self.ring_angle[np.minimum(pos, len(self.ring_key))] < angle)
            if not behind.any():
                break
            pos = pos + behind
        empty = hi == lo
        ccw = np.where(empty, -1, np.where(pos < hi, pos, lo))
        cw = np.where(empty, -1, np.where(pos > lo, pos - 1, hi - 1))
        ccw_sweep = np.where(empty, np.inf, (self.ring_angle[ccw] - angle) % _TAU)
        cw_sweep = np.where(empty, np.inf, (angle - self.ring_angle[cw]) % _TAU)
        return ccw, cw, ccw_sweep, cw_sweep


class GoalField:
    """Exact distances to one goal from every node of the graph out to `limit`, and the routes
    of starts to it (`route`)."""

    def __init__(self, graph: TangentGraph, flat: FlatGraph, goal: Point) -> None:
        self.graph, self.flat, self.goal = graph, flat, goal
        n = len(graph.rims)
        ends, exists = graph.tangents(goal)
        rows = np.flatnonzero(exists)
        free = graph._grid.free(
            np.full(len(rows), goal[0]), np.full(len(rows), goal[1]), ends[rows, 0], ends[rows, 1]
        )
        rows = rows[free]
        rim = rows % n
        xy = ends[rows]
        angle = np.arctan2(xy[:, 1] - graph._rim_y[rim], xy[:, 0] - graph._rim_x[rim])
        # the goal's free tangent points per rim (two at most): angle, point, distance
        self.ends: dict[int, list[tuple[float, Point, float]]] = {}
        for i, a, (x, y) in zip(rim.tolist(), angle.tolist(), xy.tolist(), strict=True):
            self.ends.setdefault(i, []).append((a, (x, y), dist((x, y), goal)))
        self.end_angle = np.full((n, 2), np.nan)
        self.end_dist = np.full((n, 2), np.inf)
        for i, es in self.ends.items():
            for k, (a, _, d) in enumerate(es):
                self.end_angle[i, k], self.end_dist[i, k] = a, d
        self.via: dict[int, tuple[float, Leg, Point]] = {}  # node -> (cost, arc to end, end)
        self._join_ends(rim, angle)
        self.limit = 0.0
        w = graph._world
        self.reach = 4.0 * (w.width + w.height)  # past this, the field is made whole
        self.dist: Floats = np.full(flat.goal + 1, np.inf)
        self.pred: Ints = np.full(flat.goal + 1, -9999)

    def _join_ends(self, rim: Ints, angle: Floats) -> None:
        """The goal's row: from each free tangent point along its rim to the nearest node each
        way (unless the other tangent point on the rim is nearer: that way is never shorter
        than leaving by it), if the arc is free."""
        graph, flat = self.graph, self.flat
        ccw, cw, ccw_sweep, cw_sweep = flat.neighbours(rim, angle)
        for k, (i, a) in enumerate(zip(rim.tolist(), angle.tolist(), strict=True)):
            ends = self.ends[i]
            e, d = next((p, d) for b, p, d in ends if b == a)
            others = [b for b, _, _ in ends if b != a]
            for j, sweep, out in (
                (int(ccw[k]), float(ccw_sweep[k]), True),
                (int(cw[k]), float(cw_sweep[k]), False),
            ):
                if j < 0 or any(
                    ((b - a) % _TAU if out else (a - b) % _TAU) < sweep for b in others
                ):
                    continue
                node, b = int(flat.ring_node[j]), float(flat.ring_angle[j])
                p = graph.points[node]
                arc = (
                    Arc(graph.rims[i], p, e, b, sweep, False)  # node ccw to the end
                    if not out
                    else Arc(graph.rims[i], e, p, a, sweep, True)  # node cw back to the end
                )
                cost = d + arc_length(graph.rims[i].r, sweep)
                if cost < self.via.get(node, (math.inf,))[0] and graph._arc_free(i, arc):
                    self.via[node] = (cost, arc, e)
        self.targets = np.array(list(self.via), dtype=np.int64)
        self.costs = np.array([c for c, _, _ in self.via.values()], dtype=np.float64)

    def _extend(self, limit: float) -> None:
        """Recompute the field out to `limit` (the goal's row is shared by every field)."""
        self.flat.set_goal_row(self.targets, self.costs)
        self.dist, self.pred = dijkstra(
            self.flat.matrix,
            directed=True,
            indices=self.flat.goal,
            return_predecessors=True,
            limit=limit,
        )
        self.limit = limit

    def route(self, start: Point, direct_blocked: bool = False) -> list[Leg] | None:
        """The legs of the shortest route from start to the goal, in order (None if there is
        none). The straight segment is tested first unless the caller knows it is blocked."""
        if (
            not direct_blocked
            and self.graph._grid.free_few(
                np.array([start[0]]),
                np.array([start[1]]),
                np.array([self.goal[0]]),
                np.array([self.goal[1]]),
            )[0]
        ):
            return [(start, self.goal)]
        if self.limit == 0.0:
            self._extend(2.0 * dist(start, self.goal))
        options = _Options(self, start)
        while True:
            found = options.best()
            if found is not None or self.limit == math.inf:
                return found if found is None else options.legs(found)
            need = max(2.0 * self.limit, options.needed)
            self._extend(math.inf if need > self.reach else need)
            options.reprice()


class _Options:
    """A start's ways onto the field: each free tangent point t, then along its rim to its
    nearest node (or goal tangent point) either way round; the length of each is exact. The
    tangent points are priced in order of |s − t| + |t − goal| (a lower bound of their
    options' lengths), a growing prefix at a time: an option shorter than the bound of the
    first point not priced needs no more."""

    def __init__(self, field: GoalField, start: Point) -> None:
        self.field, self.start = field, start
        graph = field.graph
        pts, exists = graph.tangents(start)
        rows = np.flatnonzero(exists)
        pts = pts[rows]
        near = np.hypot(pts[:, 0] - start[0], pts[:, 1] - start[1])
        bound = near + np.hypot(pts[:, 0] - field.goal[0], pts[:, 1] - field.goal[1])
        self.min_near = float(near.min()) if len(near) else math.inf
        self.all = (rows % len(graph.rims), pts, near, bound)
        self.m = 0
        self._sort(_PRICED)
        self.free: dict[int, bool] = {}  # tangent point -> its segment from the start is free
        self.arc_ok: dict[tuple[int, bool], bool] = {}  # (point, counter-clockwise) -> free
        self._price(min(len(rows), _PRICED))

    def _sort(self, m: int) -> None:
        """Order the tangent points by their bound: the first m, or all of them."""
        rim, pts, near, bound = self.all
        if m < len(bound):
            first = np.argpartition(bound, m)[: m + 1]  # and the smallest bound left out
            order = first[np.argsort(bound[first], kind="stable")]
        else:
            order = np.argsort(bound, kind="stable")
        self.rim, self.pts, self.near, self.bound = (
            rim[order],
            pts[order],
            near[order],
            bound[order],
        )
        self.ids = order.tolist()  # the caches below are by point, whatever its place here
        self.total = len(bound)

    def _price(self, m: int) -> None:
        """Price the options of the first m tangent points (options t and t + m: the way
        counter-clockwise and clockwise from point t)."""
        f, flat = self.field, self.field.flat
        self.m = m
        rim, pts = self.rim[:m], self.pts[:m]
        self.angle = np.arctan2(pts[:, 1] - f.graph._rim_y[rim], pts[:, 0] - f.graph._rim_x[rim])
        ccw, cw, ccw_sweep, cw_sweep = flat.neighbours(rim, self.angle)
        # a goal tangent point on the rim nearer than the node that way: the route ends there
        ends = f.end_angle[rim]
        idx = np.arange(m)
        sweeps = []
        ks = []
        for gap in ((ends - self.angle[:, None]) % _TAU, (self.angle[:, None] - ends) % _TAU):
            gap = np.where(np.isnan(gap), np.inf, gap)
            k = np.argmin(gap, axis=1)
            sweeps.append(gap[idx, k])
            ks.append(k)
        self.to_end = np.concatenate([sweeps[0] < ccw_sweep, sweeps[1] < cw_sweep])
        self.sweep = np.concatenate(
            [np.minimum(sweeps[0], ccw_sweep), np.minimum(sweeps[1], cw_sweep)]
        )
        self.end_k = np.concatenate(ks)
        self.ring_j = np.concatenate([ccw, cw])
        self.node = flat.ring_node[self.ring_j]  # the sentinel where there is none
        r = np.concatenate([f.graph._rim_r[rim]] * 2)
        self.head = np.concatenate([self.near[:m]] * 2) + arc_lengths(
            r, np.where(np.isinf(self.sweep), 0.0, self.sweep)
        )
        self.reprice()

    def reprice(self) -> None:
        """Each option's length with the field as it now is."""
        f = self.field
        tail = np.where(
            self.to_end,
            f.end_dist[np.concatenate([self.rim[: self.m]] * 2), self.end_k],
            f.dist[self.node],
        )
        self.key = self.head + np.where(np.isinf(self.sweep), np.inf, tail)
        self.order = np.argsort(self.key, kind="stable").tolist()
        self.needed = math.inf

    def best(self) -> int | None:
        """The shortest option whose tangent and arc are free and whose length the field's
        limit vouches for (None, with `needed` set, if the field must reach further)."""
        while True:
            found = self._best()
            if found != -1:
                return found
            m = min(self.total, 4 * self.m)
            self._sort(m)
            self._price(m)

    def _best(self) -> int | None:
        """`best` among the options priced; -1 if one not priced yet might be shorter."""
        f, m = self.field, self.m
        unpriced = float(self.bound[m]) if m < self.total else math.inf
        for pos, o in enumerate(self.order):
            key = float(self.key[o])
            if key > unpriced:
                return -1
            if key == math.inf:  # the rest go beyond the field's limit, or nowhere
                break
            if key > f.limit + self.min_near:
                self.needed = key - self.min_near
                return None
            t = o % m
            ids = self.ids
            if ids[t] not in self.free:
                batch = [q % m for q in self.order[pos : pos + 4 * _FEED]]
                batch = list(dict.fromkeys(q for q in batch if ids[q] not in self.free))[:_FEED]
                ok = f.graph.free_from(self.start, self.pts[batch]).tolist()
                self.free.update(zip([ids[q] for q in batch], ok, strict=True))
            if not self.free[ids[t]]:
                continue
            side = (ids[t], bool(o < m))
            if side not in self.arc_ok:
                self.arc_ok[side] = f.graph._arc_free(int(self.rim[t]), self.arc(o))
            if self.arc_ok[side]:
                return int(o)
        if unpriced < math.inf:
            return -1
        self.needed = 2.0 * f.limit
        return None

    def arc(self, o: int) -> Arc:
        """Option o's arc, from its tangent point to where it joins the field."""
        f, m = self.field, self.m
        t = o % m
        rim = int(self.rim[t])
        p = (float(self.pts[t, 0]), float(self.pts[t, 1]))
        if self.to_end[o]:
            b, q, _ = f.ends[rim][int(self.end_k[o])]
        else:
            b, q = float(f.flat.ring_angle[self.ring_j[o]]), f.graph.points[int(self.node[o])]
        sweep, c = float(self.sweep[o]), f.graph.rims[rim]
        if o < m:
            return Arc(c, p, q, float(self.angle[t]), sweep, False)
        return Arc(c, q, p, b, sweep, True)

    def legs(self, o: int) -> list[Leg]:
        """Option o's route: the tangent, the arc, then the field's predecessors to the goal."""
        f, t = self.field, o % self.m
        arc = self.arc(o)
        out: list[Leg] = [(self.start, (float(self.pts[t, 0]), float(self.pts[t, 1]))), arc]
        if self.to_end[o]:
            out.append((arc.p if arc.reverse else arc.q, f.goal))
            return out
        u = int(self.node[o])
        adj, pred, goal = f.graph.adj, f.pred, f.flat.goal
        while int(pred[u]) != goal:
            v = int(pred[u])
            out.append(min((c, i, leg) for i, (w, c, leg) in enumerate(adj[u]) if w == v)[2])
            u = v
        _, last, e = f.via[u]
        out.extend([last, (e, f.goal)])
        return out
