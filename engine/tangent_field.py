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
from typing import TYPE_CHECKING

import numpy as np
from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

from engine.geometry import Point, dist
from engine.rims import Arc, arc_length
from engine.tangent_arrays import TAU, FlatGraph, Floats, Ints, StartFan, arc_lengths

if TYPE_CHECKING:
    from engine.tangent_query import Leg, TangentGraph

_FEED = 4
"""Start tangents whose segments are tested together (the first is most often the one)."""
_PRICED = 24
"""A start's tangent points priced first (then 4× as many, as long as one might be shorter)."""
LIMIT_OVER_STRAIGHT = 1.25
"""A new field is computed out to this many times its first start's straight distance (then
doubled as starts need): most routes are a few per cent longer than the straight line, and
Dijkstra's cost grows with the area inside the limit (2.0 made each field ~1.3x as dear at
scale 100). The answers do not depend on it: a node past the limit reads as farther than
any option found within it, so such an option is settled only when it is truly shortest."""


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
                if j < 0 or any(((b - a) % TAU if out else (a - b) % TAU) < sweep for b in others):
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

    def route(self, fan: StartFan, direct_blocked: bool = False) -> list[Leg] | None:
        """The legs of the shortest route from the fan's start to the goal, in order (None if
        there is none). The straight segment is tested first unless the caller knows it is
        blocked."""
        start, goal = fan.start, self.goal
        if not direct_blocked and self.graph.free_from(start, np.array([goal]))[0]:
            return [(start, goal)]
        if self.limit == 0.0:
            self._extend(LIMIT_OVER_STRAIGHT * dist(start, goal))
        options = _Options(self, fan)
        while True:
            found = options.best()
            if found is not None or self.limit == math.inf:
                return found if found is None else options.legs(*found)
            need = max(2.0 * self.limit, options.needed)
            self._extend(math.inf if need > self.reach else need)
            options.reprice()


class _Options:
    """A start's ways onto the field: each free tangent point t, then along its rim to its
    nearest node (or goal tangent point) either way round; the length of each is exact. The
    tangent points are priced in order of |s − t| + |t − goal| (a lower bound of their
    options' lengths), a growing prefix at a time: an option shorter than the bound of the
    first point not priced needs no more. An option is (point, side), side 0 the way
    counter-clockwise, 1 clockwise."""

    def __init__(self, field: GoalField, fan: StartFan) -> None:
        self.field, self.fan = field, fan
        g = field.goal
        self.bound = fan.near + np.hypot(fan.pts[:, 0] - g[0], fan.pts[:, 1] - g[1])
        self.total = len(self.bound)
        self.arc_ok: dict[tuple[int, int], bool] = {}  # (point, side) -> its arc to a goal end
        self._price(min(self.total, _PRICED))

    def _price(self, m: int) -> None:
        """Order the tangent points by their bound and price the options of the first m."""
        bound, fan, f = self.bound, self.fan, self.field
        if m < self.total:
            first = np.argpartition(bound, m)[: m + 1]  # and the smallest bound left out
            order = first[np.argsort(bound[first], kind="stable")]
            self.unpriced = float(bound[order[m]])
            ids = order[:m]
        else:
            ids = np.argsort(bound, kind="stable")
            self.unpriced = math.inf
        self.ids = ids
        rim, angle = fan.rim[ids], fan.angle[ids]
        # a goal tangent point on the rim nearer than the node that way: the route ends there
        ends = f.end_angle[rim]  # nan where none
        sweeps, ks = [], []
        for gap in ((ends - angle[:, None]) % TAU, (angle[:, None] - ends) % TAU):
            gap = np.where(np.isnan(gap), np.inf, gap)
            second = gap[:, 1] < gap[:, 0]
            sweeps.append(np.where(second, gap[:, 1], gap[:, 0]))
            ks.append(second.astype(np.int64))
        e_sweep = np.stack(sweeps, axis=1)
        self.end_k = np.stack(ks, axis=1)
        self.to_end = e_sweep < fan.sweep[ids]
        self.sweep = np.where(self.to_end, e_sweep, fan.sweep[ids])
        self.head = fan.heads(ids)
        self.end_dist = np.full(self.end_k.shape, np.inf)
        if self.to_end.any():
            end_head = fan.near[ids][:, None] + arc_lengths(
                f.graph._rim_r[rim][:, None], np.where(self.to_end, e_sweep, 0.0)
            )
            self.head = np.where(self.to_end, end_head, self.head)
            dists = f.end_dist[rim]
            self.end_dist = np.where(self.end_k == 1, dists[:, 1:2], dists[:, 0:1])
        self.reprice()

    def reprice(self) -> None:
        """Each option's length with the field as it now is."""
        tail = np.where(self.to_end, self.end_dist, self.field.dist[self.fan.node[self.ids]])
        self.key = (self.head + np.where(np.isinf(self.sweep), np.inf, tail)).ravel()
        self.order = np.argsort(self.key, kind="stable").tolist()
        self.needed = math.inf

    def best(self) -> tuple[int, int] | None:
        """The shortest option whose tangent and arc are free and whose length the field's
        limit vouches for (None, with `needed` set, if the field must reach further)."""
        while True:
            found = self._best()
            if found != (-1, -1):
                return found
            self._price(min(self.total, 4 * len(self.ids)))

    def _best(self) -> tuple[int, int] | None:
        """`best` among the options priced; (-1, -1) if one not priced yet might be shorter."""
        f, fan, ids = self.field, self.fan, self.ids.tolist()
        for pos, o in enumerate(self.order):
            key = float(self.key[o])
            if key > self.unpriced:
                return (-1, -1)
            if key == math.inf:  # the rest go beyond the field's limit, or nowhere
                break
            if key > f.limit + fan.min_near:
                self.needed = key - fan.min_near
                return None
            t, side = ids[o // 2], o % 2
            if t not in fan.free:
                batch = [ids[q // 2] for q in self.order[pos : pos + 4 * _FEED]]
                batch = list(dict.fromkeys(q for q in batch if q not in fan.free))[:_FEED]
                ok = f.graph.free_from(fan.start, fan.pts[batch]).tolist()
                fan.free.update(zip(batch, ok, strict=True))
            if not fan.free[t]:
                continue
            cache = self.arc_ok if self.to_end[o // 2, side] else fan.arc_ok
            if (t, side) not in cache:
                cache[t, side] = f.graph._arc_free(int(fan.rim[t]), self.arc(o // 2, side))
            if cache[t, side]:
                return (o // 2, side)
        if self.unpriced < math.inf:
            return (-1, -1)
        self.needed = 2.0 * f.limit
        return None

    def arc(self, k: int, side: int) -> Arc:
        """The arc of option (k-th point priced, side): from the point to where it joins the
        field."""
        f, fan = self.field, self.fan
        t = int(self.ids[k])
        rim = int(fan.rim[t])
        p = (float(fan.pts[t, 0]), float(fan.pts[t, 1]))
        if self.to_end[k, side]:
            b, q, _ = f.ends[rim][int(self.end_k[k, side])]
        else:
            b = float(f.flat.ring_angle[fan.ring_j[t, side]])
            q = f.graph.points[int(fan.node[t, side])]
        sweep, c = float(self.sweep[k, side]), f.graph.rims[rim]
        if side == 0:
            return Arc(c, p, q, float(fan.angle[t]), sweep, False)
        return Arc(c, q, p, b, sweep, True)

    def legs(self, k: int, side: int) -> list[Leg]:
        """The option's route: the tangent, the arc, then the field's predecessors to the
        goal."""
        f, fan = self.field, self.fan
        t = int(self.ids[k])
        arc = self.arc(k, side)
        out: list[Leg] = [(fan.start, (float(fan.pts[t, 0]), float(fan.pts[t, 1]))), arc]
        if self.to_end[k, side]:
            out.append((arc.p if arc.reverse else arc.q, f.goal))
            return out
        u = int(fan.node[t, side])
        adj, pred, goal = f.graph.adj, f.pred, f.flat.goal
        while int(pred[u]) != goal:
            v = int(pred[u])
            out.append(min((c, i, leg) for i, (w, c, leg) in enumerate(adj[u]) if w == v)[2])
            u = v
        _, last, e = f.via[u]
        out.extend([last, (e, f.goal)])
        return out
