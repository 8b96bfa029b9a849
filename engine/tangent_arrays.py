"""The exact planner's tangent graph (engine/tangent_planner.py) as arrays, for the distance
fields of engine/tangent_field.py: the whole graph as a CSR matrix for scipy's Dijkstra, every
rim's nodes sorted by angle, and a start's fan: its tangent points and their nearest nodes
either way round on their rims, which depend on the start alone and are kept for the next
goal it prices (an idle robot prices every task it hears from where it stands).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix  # type: ignore[import-untyped]

from engine.geometry import Point
from engine.rims import ARC_STEP

if TYPE_CHECKING:
    from engine.tangent_query import TangentGraph

Ints = npt.NDArray[np.int64]
Ints32 = npt.NDArray[np.int32]
"""Indices kept by the thousand (a start's fan): half the bytes of `Ints`, the same answers."""
Floats = npt.NDArray[np.float64]

_SLOTS_PER_RIM = 4
"""The goal's row in the matrix: two tangents per rim, each joined to a node either way."""
TAU = 2.0 * math.pi


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
        ccw_sweep = np.where(empty, np.inf, (self.ring_angle[ccw] - angle) % TAU)
        cw_sweep = np.where(empty, np.inf, (angle - self.ring_angle[cw]) % TAU)
        return ccw, cw, ccw_sweep, cw_sweep


class StartFan:
    """A start's tangent points (row i and i + n on rim i, as `TangentGraph.tangents`, only
    those that exist), their lengths from the start, and each one's nearest node on its rim
    counter-clockwise (side 0) and clockwise (side 1): index in the ring arrays, the node, the
    sweep, and the length to it (start → point → node). Segments and arcs found free or
    blocked are remembered here too: they do not depend on the goal."""

    def __init__(self, graph: TangentGraph, flat: FlatGraph, start: Point) -> None:
        self.start = start
        pts, exists = graph.tangents(start)
        rows = np.flatnonzero(exists)
        self.pts = pts[rows]
        rim = rows % len(graph.rims)
        self.rim: Ints32 = rim.astype(np.int32)
        self.near = np.hypot(self.pts[:, 0] - start[0], self.pts[:, 1] - start[1])
        self.min_near = float(self.near.min()) if len(rows) else math.inf
        self.angle = np.arctan2(
            self.pts[:, 1] - graph._rim_y[rim], self.pts[:, 0] - graph._rim_x[rim]
        )
        ccw, cw, ccw_sweep, cw_sweep = flat.neighbours(rim, self.angle)
        self.ring_j: Ints32 = np.stack([ccw, cw], axis=1).astype(np.int32)
        self.node: Ints32 = flat.ring_node[self.ring_j].astype(np.int32)  # sentinel if none
        self.sweep = np.stack([ccw_sweep, cw_sweep], axis=1)
        self._rim_r = graph._rim_r
        self.free: dict[int, bool] = {}  # point -> its segment from the start is free
        self.arc_ok: dict[tuple[int, int], bool] = {}  # (point, side) -> its arc to the node

    def heads(self, ids: Ints) -> Floats:
        """These points' lengths start → point → node, each way round (made when asked, not
        kept: a planner keeps a thousand fans, and this was a sixth of their bytes)."""
        sweep = self.sweep[ids]
        r = self._rim_r[self.rim[ids]][:, None]
        return self.near[ids][:, None] + arc_lengths(r, np.where(np.isinf(sweep), 0.0, sweep))
