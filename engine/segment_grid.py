"""Many segments tested against the craters at once: a uniform grid and numpy.

The tangent graph tests every bitangent of every pair of craters (hundreds of thousands at
600 craters) and every query tests its start's and goal's tangents; one Python call per
segment, each looking at every crater in the segment's bounding box, grew with the square
(cube) of the craters. Here all segments are marched in lock-step, one sample per `step`
along each, and a segment is tested only against the craters registered in its samples'
cells; a segment leaves the march at its first blocking crater, so a long blocked segment
costs as little as a short one.

Exact, not approximate: every point of a segment is within step/2 of one of its samples, so a
crater the segment comes within r of is within r + step/2 of a sample, and each crater is
registered in every cell its disc of radius r + step/2 touches. The final test is the same as
`CraterIndex.segment_free`'s: the distance from the crater's centre to the whole segment.
When few segments are left (or were given), they are tested against every disc at once.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

Floats = npt.NDArray[np.float64]
Bools = npt.NDArray[np.bool_]

_CHUNK = 65536
"""Segments marched together (bounds the temporary arrays to a few MB)."""
_DIRECT = 100_000
"""Up to this many segment × disc pairs, every segment is tested against every disc."""
_MARGIN = 1e-6
"""Metres added round a bounding box, so rounding never drops a disc that touches it."""
_FAR = 1e18
"""Centre of the padding crater that fills short cells (radius -1: never blocks)."""


class SegmentGrid:
    """Discs (x, y, r) bucketed on a square grid for vectorized segment tests."""

    def __init__(self, xyr: Floats, step: float) -> None:
        self.step = step
        n = len(xyr)
        reach = xyr[:, 2] + step / 2.0 if n else np.zeros(0)
        self.x0 = float((xyr[:, 0] - reach).min()) if n else 0.0
        self.y0 = float((xyr[:, 1] - reach).min()) if n else 0.0
        lo_x = np.floor((xyr[:, 0] - reach - self.x0) / step).astype(np.int64)
        hi_x = np.floor((xyr[:, 0] + reach - self.x0) / step).astype(np.int64)
        lo_y = np.floor((xyr[:, 1] - reach - self.y0) / step).astype(np.int64)
        hi_y = np.floor((xyr[:, 1] + reach - self.y0) / step).astype(np.int64)
        self.cols = int(hi_x.max()) + 1 if n else 1
        self.rows = int(hi_y.max()) + 1 if n else 1
        buckets: list[list[int]] = [[] for _ in range(self.cols * self.rows)]
        for k in range(n):
            for cx in range(int(lo_x[k]), int(hi_x[k]) + 1):
                for cy in range(int(lo_y[k]), int(hi_y[k]) + 1):
                    buckets[cy * self.cols + cx].append(k)
        width = max(1, max(map(len, buckets)))
        table = np.full((len(buckets), width), n, dtype=np.int64)  # n: the padding disc
        for cell, ks in enumerate(buckets):
            table[cell, : len(ks)] = ks
        self.table = table
        pad = np.array([[_FAR, _FAR, -1.0]])
        self.discs = np.concatenate([xyr.reshape(-1, 3), pad])

    def free(self, ax: Floats, ay: Floats, bx: Floats, by: Floats) -> Bools:
        """For each segment a → b: no disc comes within its radius of it (strictly)."""
        out = np.ones(len(ax), dtype=bool)
        for lo in range(0, len(ax), _CHUNK):
            hi = lo + _CHUNK
            out[lo:hi] = self._free(ax[lo:hi], ay[lo:hi], bx[lo:hi], by[lo:hi])
        return out

    def free_few(self, ax: Floats, ay: Floats, bx: Floats, by: Floats) -> Bools:
        """`free` for a handful of segments: each against every disc near their bounding box
        at once, which beats the march's per-sample numpy calls when there are few (the same
        test, the same answers: a disc whose box misses theirs is farther than its radius)."""
        discs = self.discs
        near = (
            (discs[:, 0] + discs[:, 2] >= min(ax.min(), bx.min()) - _MARGIN)
            & (discs[:, 0] - discs[:, 2] <= max(ax.max(), bx.max()) + _MARGIN)
            & (discs[:, 1] + discs[:, 2] >= min(ay.min(), by.min()) - _MARGIN)
            & (discs[:, 1] - discs[:, 2] <= max(ay.max(), by.max()) + _MARGIN)
        )
        dx, dy = bx - ax, by - ay
        seg2 = dx * dx + dy * dy
        return self._direct(ax, ay, dx, dy, np.where(seg2 > 0.0, seg2, 1.0), discs[near])

    def _direct(
        self, ax: Floats, ay: Floats, dx: Floats, dy: Floats, safe2: Floats, discs: Floats
    ) -> Bools:
        """Each segment against every one of these discs at once."""
        ex = discs[None, :, 0] - ax[:, None]
        ey = discs[None, :, 1] - ay[:, None]
        u = np.clip((ex * dx[:, None] + ey * dy[:, None]) / safe2[:, None], 0.0, 1.0)
        gap = np.hypot(u * dx[:, None] - ex, u * dy[:, None] - ey)
        return np.asarray((gap > discs[None, :, 2]).all(axis=1))

    def _free(self, ax: Floats, ay: Floats, bx: Floats, by: Floats) -> Bools:
        dx, dy = bx - ax, by - ay
        seg2 = dx * dx + dy * dy
        safe2 = np.where(seg2 > 0.0, seg2, 1.0)
        free = np.ones(len(ax), dtype=bool)
        length = np.sqrt(seg2)
        samples = np.ceil(length / self.step).astype(np.int64)  # the last one is at b
        inv = np.where(length > 0.0, 1.0 / np.where(length > 0.0, length, 1.0), 0.0)
        disc_x, disc_y, disc_r = self.discs[:, 0], self.discs[:, 1], self.discs[:, 2]
        active = np.arange(len(ax))
        m = 0
        while active.size:
            if active.size * len(self.discs) <= _DIRECT:  # few left: every disc at once
                free[active] = self._direct(
                    ax[active], ay[active], dx[active], dy[active], safe2[active], self.discs
                )
                break
            a_x, a_y, d_x, d_y = ax[active], ay[active], dx[active], dy[active]
            t = np.minimum(m * self.step * inv[active], 1.0)
            col = ((a_x + t * d_x - self.x0) // self.step).astype(np.int64)
            row = ((a_y + t * d_y - self.y0) // self.step).astype(np.int64)
            col = np.minimum(np.maximum(col, 0), self.cols - 1)
            row = np.minimum(np.maximum(row, 0), self.rows - 1)
            cand = self.table[row * self.cols + col]  # (segments, width)
            cx, cy, cr = disc_x[cand], disc_y[cand], disc_r[cand]
            ex, ey = cx - a_x[:, None], cy - a_y[:, None]
            u = (ex * d_x[:, None] + ey * d_y[:, None]) / safe2[active][:, None]
            u = np.minimum(np.maximum(u, 0.0), 1.0)
            gap = np.hypot(u * d_x[:, None] - ex, u * d_y[:, None] - ey)
            blocked = (gap <= cr).any(axis=1)
            free[active[blocked]] = False
            active = active[~blocked & (samples[active] > m)]
            m += 1
        return free


def grid_step(xyr: Floats, width: float, height: float) -> float:
    """A cell side for these discs: about the mean spacing of their centres, never less than a
    disc's diameter (few discs per cell, few samples per segment)."""
    if len(xyr) == 0:
        return max(width, height, 1.0)
    spacing = math.sqrt(width * height / len(xyr))
    return max(float(2.0 * xyr[:, 2].max()), 0.5 * spacing)
