"""The scouts' outward spiral over the search grid, split into one angular sector per scout.

Cells are taken ring by ring (Chebyshev distance from the plant's cell), so cells near the
plant are scanned first. Each ring is cut into as many arcs as there are scouts, by the
angle of the cell around the plant; scout i sweeps arc i of every ring, alternating its
direction from ring to ring so the step to the next ring is short. Every cell belongs to
exactly one arc, so no cell is missed and none is scanned twice. Cells that are entirely
crater have no scan point and no route entry (no site can lie there).
"""

from __future__ import annotations

import math

from engine.world import SearchGrid


def spiral_routes(grid: SearchGrid, plant: tuple[float, float], n_scouts: int) -> list[list[int]]:
    """Each scout's ordered list of cells to scan."""
    if n_scouts < 1:
        raise ValueError("n_scouts must be at least 1")
    pc = grid.cell_of(*plant)
    pr, pcol = divmod(pc, grid.cols)
    max_ring = max(pr, grid.rows - 1 - pr, pcol, grid.cols - 1 - pcol)
    routes: list[list[int]] = [[] for _ in range(n_scouts)]
    if grid.waypoints[pc] is not None:
        routes[0].append(pc)
    sector = 2 * math.pi / n_scouts
    for d in range(1, max_ring + 1):
        arcs: list[list[tuple[float, int]]] = [[] for _ in range(n_scouts)]
        for r in range(pr - d, pr + d + 1):
            if not 0 <= r < grid.rows:
                continue
            edge_row = r in (pr - d, pr + d)
            cols = range(pcol - d, pcol + d + 1) if edge_row else (pcol - d, pcol + d)
            for c in cols:
                if not 0 <= c < grid.cols or grid.waypoints[r * grid.cols + c] is None:
                    continue  # outside the area, or all crater: nothing to scan there
                # angle in [0, 2π) measured from the plant cell, ties broken by cell index
                a = math.atan2(r - pr, c - pcol) % (2 * math.pi)
                arcs[min(n_scouts - 1, int(a / sector))].append((a, r * grid.cols + c))
        for i, arc in enumerate(arcs):
            arc.sort(reverse=(d % 2 == 0))
            routes[i].extend(cell for _, cell in arc)
    return routes
