"""A lower bound on a mission's makespan from its scenario and world alone.

The bound holds for every allocation policy, decentralized or central: it uses only the
physics (speeds, the straight line as the shortest path), the task chain (find → dig →
transfer → haul → unload), the scouts' spiral (docs/spec.md §7, fixed before any auction) and the
robots' start ring. docs/experiments.md derives each term; `makespan / bound` then says how
far a run is from the best any allocator could possibly do.

Two bounds come from the same terms. The *a-priori* bound (`lower_bound(w)`) knows only the
world: for each site it uses the earliest time any scout on its spiral could have found it.
The *per-run* bound (`run_bound(w, found_at)`) puts each site's actual discovery time in that
run in their place. It is a valid bound on that run's makespan: a site cannot be dug before
it is found (only a scout's scan finds it, and no excavate auction exists before), and the
mission does not end before every site is found, so the actual times are earliest-find times
of that run exactly; every other term is physics (speeds, straight lines, the task chain, the
team sizes) and holds for any schedule given those times. It only says how far the run is
from the best any allocator could do *with the discoveries as they happened*; since the
scouts' spiral is fixed before any auction, only the planner's detours around craters make
them differ between policies.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

Point = tuple[float, float]

_LEG_BLOCK = 256
"""Route legs tested against the craters at once (256 x 600 craters: a few MB)."""


@dataclass(frozen=True)
class BoundWorld:
    """What the bound needs: geometry, team and timing. No robot decisions."""

    plant: Point
    sites: tuple[tuple[float, float, int], ...]  # x, y, minerals
    scout_routes: tuple[tuple[Point, ...], ...]  # each scout's waypoints in order; () = unknown
    start_spread: float  # every robot starts within this distance of the plant
    craters: tuple[tuple[float, float, float], ...]  # x, y, radius
    clearance: float  # the planner keeps this far from rims (plus a safety margin)
    scan_radius: float
    scouts: int
    excavators: int
    haulers: int
    v_scout: float
    v_excavator: float
    v_hauler: float
    dig_s: float
    transfer_s: float
    unload_s: float


@dataclass(frozen=True)
class Bound:
    value: float
    terms: dict[str, float]  # every term; the bound is their maximum
    found_s: tuple[float, ...]  # per site: no scout can have found it earlier
    world: BoundWorld | None = field(default=None, compare=False, repr=False)  # for run_bound


def found_bounds(w: BoundWorld) -> np.ndarray:
    """Per site, the earliest time any scout on its spiral route can come within scan range.

    A scout drives its waypoints A₁, A₂, … in order at constant speed, starting within σ of
    the plant P. It has driven at least p₁ = max(0, |A₁−P|−σ) on reaching A₁ and at least
    pᵢ₊₁ = pᵢ + |Aᵢ−Aᵢ₊₁| on reaching Aᵢ₊₁ (straight lines are shortest). A leg whose
    straight segment is clear of every inflated crater is driven straight (the engine's
    planners return the segment itself), so a site is seen on it exactly where the segment
    first comes within r. On any other leg the scout stays within (arclength since Aᵢ) of
    Aᵢ, so it cannot see site x before pᵢ + max(0, |Aᵢ−x|−r).
    """
    px, py = w.plant
    xy = np.asarray([(s[0], s[1]) for s in w.sites], dtype=float).reshape(-1, 2)
    d_plant = np.hypot(xy[:, 0] - px, xy[:, 1] - py)
    r = w.scan_radius * (1 + 1e-9) + 1e-9  # a hair wider: only ever earlier
    reach_any = np.maximum(0.0, d_plant - w.start_spread - r)  # any path from the start ring
    if not w.scout_routes:
        return np.asarray(reach_any / w.v_scout)
    best = np.full(len(xy), np.inf)
    craters = np.asarray(w.craters, dtype=float).reshape(-1, 3)  # once per world
    for route in w.scout_routes:
        if not route:  # a scout without cells: allow it anything
            best = np.minimum(best, reach_any)
            continue
        a = np.asarray(route, dtype=float)
        # the first leg: straight if the disc around P holding the start and A₁ is clear
        rho = max(w.start_spread, math.hypot(a[0, 0] - px, a[0, 1] - py))
        if _disc_clear(w, rho):
            best = np.minimum(best, np.where(d_plant - r <= rho, reach_any, np.inf))
        else:
            best = np.minimum(best, reach_any)
        first = max(0.0, math.hypot(a[0, 0] - px, a[0, 1] - py) - w.start_spread)
        leg = np.hypot(np.diff(a[:, 0]), np.diff(a[:, 1]))
        prefix = first + np.concatenate([[0.0], np.cumsum(leg)])[:-1]
        straight = _legs_clear(a, craters, w.clearance)
        for lo in range(0, len(xy), 64):  # sites in chunks: memory stays small when scaled
            chunk = xy[lo : lo + 64]
            t = _leg_bounds(a, leg, prefix, straight, chunk, r)
            best[lo : lo + 64] = np.minimum(best[lo : lo + 64], t)
    # a site no route passes: the engine never places one, but stay valid if it did
    best = np.where(np.isfinite(best), best, reach_any)
    return np.asarray(best / w.v_scout)


def _leg_bounds(
    a: np.ndarray,
    leg: np.ndarray,
    prefix: np.ndarray,
    straight: np.ndarray,
    x: np.ndarray,
    r: float,
) -> np.ndarray:
    """Per site in x: the least arclength at which some leg of route a can see it."""
    if len(leg) == 0:
        d0 = np.hypot(x[:, 0] - a[0, 0], x[:, 1] - a[0, 1])
        return np.where(d0 <= r, 0.0, np.inf) + (prefix[0] if len(prefix) else 0.0)
    p0 = a[None, :-1, :]
    dv = (a[1:] - a[:-1])[None, :, :]
    f = p0 - x[:, None, :]
    aa = (dv**2).sum(-1)
    bb = 2.0 * (f * dv).sum(-1)
    cc = (f**2).sum(-1) - r * r
    disc = bb * bb - 4.0 * aa * cc
    with np.errstate(invalid="ignore", divide="ignore"):
        u = (-bb - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * aa)
    hit = (cc <= 0) | ((disc >= 0) & (aa > 0) & (u >= 0) & (u <= 1))
    u = np.where(cc <= 0, 0.0, u)
    exact = np.where(hit, prefix[None, :] + u * leg[None, :], np.inf)
    loose = prefix[None, :] + np.maximum(0.0, np.sqrt(np.maximum(cc + r * r, 0.0)) - r)
    per_leg = np.where(straight[None, :], exact, loose)
    # the end of the route: the scout stops at its last waypoint
    last = np.hypot(x[:, 0] - a[-1, 0], x[:, 1] - a[-1, 1])
    at_end = np.where(last <= r, prefix[-1] + leg[-1], np.inf)
    return np.asarray(np.minimum(per_leg.min(axis=1), at_end))


def _legs_clear(a: np.ndarray, craters: np.ndarray, clearance: float) -> np.ndarray:
    """Per leg of route `a`: clear of every crater (rows x, y, r) inflated by the planner's
    clearance (with a safety margin). Legs in blocks against every crater at once: one leg at
    a time in Python took minutes per run at scale 100 (a hundred spirals, 600 craters)."""
    out = np.ones(max(0, len(a) - 1), dtype=bool)
    if len(craters) == 0:
        return out
    cx, cy = craters[None, :, 0], craters[None, :, 1]
    limit = craters[None, :, 2] + clearance
    for lo in range(0, len(out), _LEG_BLOCK):
        q = a[lo + 1 : lo + _LEG_BLOCK + 1]
        p = a[lo : lo + len(q)]
        px, py = p[:, 0:1], p[:, 1:2]
        dx, dy = q[:, 0:1] - px, q[:, 1:2] - py
        seg2 = dx * dx + dy * dy
        with np.errstate(invalid="ignore", divide="ignore"):
            u = np.clip(((cx - px) * dx + (cy - py) * dy) / seg2, 0.0, 1.0)
        u = np.where(seg2 == 0, 0.0, u)
        gap = np.hypot(px + u * dx - cx, py + u * dy - cy)
        out[lo : lo + len(q)] = (gap > limit).all(axis=1)
    return out


def _disc_clear(w: BoundWorld, rho: float) -> bool:
    px, py = w.plant
    return all(math.hypot(cx - px, cy - py) - cr - w.clearance > rho for cx, cy, cr in w.craters)


def mst_length(points: Sequence[Point]) -> float:
    """Euclidean minimum spanning tree (Prim, O(n²)): fine for thousands of sites."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    n = len(p)
    if n < 2:
        return 0.0
    inside = np.zeros(n, dtype=bool)
    dist = np.hypot(p[:, 0] - p[0, 0], p[:, 1] - p[0, 1])
    inside[0] = True
    total = 0.0
    for _ in range(n - 1):
        cand = np.where(inside, np.inf, dist)
        k = int(np.argmin(cand))
        total += float(cand[k])
        inside[k] = True
        dist = np.minimum(dist, np.hypot(p[:, 0] - p[k, 0], p[:, 1] - p[k, 1]))
    return total


def _release_bound(
    release: np.ndarray, work: np.ndarray, machines: int, tail: np.ndarray, credit: np.ndarray
) -> float:
    """max over τ of τ + (Σ work of jobs released ≥ τ − the `machines` largest credits)/machines
    + the smallest tail among them: identical machines, one job at a time, release dates."""
    order = np.argsort(release, kind="stable")
    best = 0.0
    for i in range(len(order)):
        tau = float(release[order[i]])
        if i and release[order[i - 1]] == tau:
            continue
        rest = order[i:]
        cut = np.sort(credit[rest])[::-1][:machines].sum()
        value = tau + (work[rest].sum() - cut) / machines + float(tail[rest].min())
        best = max(best, value)
    return best


def lower_bound(w: BoundWorld, found_s: Sequence[float] | None = None) -> Bound:
    """The largest of the search, chain, haulage and digging bounds (each a valid bound).

    `found_s`, per site, times before which it cannot have been found: by default the
    a-priori `found_bounds(w)`; `run_bound` passes one run's actual discovery times.
    """
    px, py = w.plant
    found = found_bounds(w) if found_s is None else np.asarray(found_s, dtype=float)
    if found.shape != (len(w.sites),):
        raise ValueError(f"found_s: {len(w.sites)} sites, got {found.shape}")
    d = np.asarray([math.hypot(x - px, y - py) for x, y, _ in w.sites])
    m = np.asarray([n for _, _, n in w.sites], dtype=int)
    sigma, r = w.start_spread, w.scan_radius
    dt = w.dig_s + w.transfer_s
    # an excavator digs a site only once it is found and reached (it starts within σ)
    arrive = np.maximum(found, np.maximum(0.0, d - sigma) / w.v_excavator)
    back = d / w.v_hauler + w.unload_s  # last pickup → plant → unloaded
    terms: dict[str, float] = {
        "search_spiral": float(found.max()),
        "search_cover": max(
            0.0,
            (mst_length([w.plant, *[(x, y) for x, y, _ in w.sites]]) - w.scouts * sigma
             - (2 * len(w.sites) - 1) * r) / (w.scouts * w.v_scout),
        ),
        "chain": float((arrive + m * dt + back).max()),
    }  # fmt: skip
    # one job per mineral: the k-th of a site is dug after k digs and k−1 transfers there
    site = np.repeat(np.arange(len(m)), m)
    k = np.concatenate([np.arange(n) for n in m]) if len(m) else np.zeros(0, int)
    pickup = arrive[site] + (k + 1) * w.dig_s + k * w.transfer_s
    trip = 2 * d[site] / w.v_hauler + w.transfer_s + w.unload_s
    total_trip = float(trip.sum())
    terms["haul_work"] = (total_trip - w.haulers * sigma / w.v_hauler) / w.haulers
    # after τ, each hauler's first trip may start anywhere: credit its outbound leg
    zero = np.zeros(len(site))
    terms["haul_release"] = _release_bound(pickup, trip, w.haulers, zero, d[site] / w.v_hauler)
    dig_start = arrive[site] + k * dt
    terms["dig_release"] = _release_bound(
        dig_start, np.full(len(site), dt), w.excavators, back[site], zero
    )
    terms = {k: float(v) for k, v in terms.items()}
    return Bound(max(terms.values()), terms, tuple(float(f) for f in found), w)


def run_bound(w: BoundWorld, found_at: Sequence[float | None] | None) -> Bound | None:
    """The per-run bound: the same terms with the run's actual discovery times (the engine's
    `sites_found_at`, in world order) as each site's earliest-find time.

    None unless every site was found (a run that did not complete has no makespan to bound)
    or when the times do not fit the world. Valid for that run because nothing can be dug
    before it is found and the mission ends only once every site is found; every other term
    is physics (see the module docstring). Meant for fault-free runs, like every term here.
    """
    if found_at is None or len(found_at) != len(w.sites):
        return None
    if any(not isinstance(t, (int, float)) or not math.isfinite(t) for t in found_at):
        return None
    return lower_bound(w, [float(t) for t in found_at])  # type: ignore[arg-type]


def bound_world(scenario: Any, seed: int) -> BoundWorld:
    """The world a run of (scenario, seed) plays in, as the engine generates it.

    Builds the mission with the straight-line planner (the world and the scout routes do
    not depend on the planner) and reads its world and spiral routes. On a lossy or slow bus
    a scout may be wrongly declared failed and its cells handed to another, so the spiral
    is then not relied on (routes left empty: only the route-free search bound applies).
    """
    from engine import Mission
    from engine.world import CLEARANCE

    mission = Mission(scenario, seed, planner="straight")
    try:
        world = mission.world
        wps = world.grid.waypoints
        routes: tuple[tuple[Point, ...], ...] = tuple(
            tuple((float(wps[c][0]), float(wps[c][1])) for c in cells)  # type: ignore[index]
            for _, cells in sorted(mission.routes.items())
        )
    finally:
        mission.close()
    s = scenario
    if s.bus.loss > 0 or s.bus.latency_s > 0 or s.bus.jitter_s > 0:
        routes = ()
    return BoundWorld(
        plant=world.plant,
        sites=tuple((site.x, site.y, site.minerals) for site in world.sites),
        scout_routes=routes,
        start_spread=s.start_spread,
        craters=tuple((c.x, c.y, c.r) for c in world.craters),
        clearance=CLEARANCE + 0.01,
        scan_radius=s.scan_radius,
        scouts=s.team.scouts,
        excavators=s.team.excavators,
        haulers=s.team.haulers,
        v_scout=s.speeds.scout,
        v_excavator=s.speeds.excavator,
        v_hauler=s.speeds.hauler,
        dig_s=s.timing.dig_s,
        transfer_s=s.timing.transfer_s,
        unload_s=s.timing.unload_s,
    )


BoundFn = Callable[[Any, int], Bound]


def engine_bound(scenario: Any, seed: int) -> Bound:
    """The bound of the world the engine generates for (scenario, seed)."""
    return lower_bound(bound_world(scenario, seed))


def _uncertain(scenario: Any) -> bool:
    unc = getattr(scenario, "uncertainty", None)
    return bool(unc is not None and unc.enabled)


def bound_columns(
    rows: list[dict[str, Any]], scenario: Any, bound_fn: BoundFn
) -> list[dict[str, Any]]:
    """Add both bounds and both ratios to each run; return the a-priori terms per seed.

    Per run: `lower_bound_s` is the per-run bound (`run_bound` with the run's
    `sites_found_at`; None when the run did not complete, its discovery times are missing or
    `bound_fn` gives no world), `lower_bound_term` its binding term, `makespan_ratio` the
    makespan over it; `lower_bound_apriori_s` and `makespan_ratio_apriori` are the same for
    the a-priori bound of the run's seed. Ratios only for completed runs.
    """
    per_seed: dict[int, Bound] = {}
    for row in rows:
        seed = int(row["seed"])
        if seed not in per_seed:
            per_seed[seed] = bound_fn(scenario, seed)
        b = per_seed[seed]
        mk = row.get("makespan_s")
        ok = isinstance(mk, (int, float)) and row.get("status", "completed") == "completed"
        # uncertain work: drawn durations and speeds can beat the bound's fixed ones
        ok = ok and not _uncertain(scenario)
        rb = (
            run_bound(b.world, _found_at(row.get("sites_found_at")))
            if ok and b.world is not None
            else None
        )
        row["lower_bound_s"] = rb.value if rb is not None else None
        row["lower_bound_apriori_s"] = b.value
        row["lower_bound_term"] = _binding(rb) if rb is not None else None
        row["makespan_ratio"] = _ratio(mk, rb.value if rb is not None else None) if ok else None
        row["makespan_ratio_apriori"] = _ratio(mk, b.value) if ok else None
    return [
        {
            "seed": seed,
            "lower_bound_apriori_s": b.value,
            **{f"{k}_s": v for k, v in b.terms.items()},
        }
        for seed, b in sorted(per_seed.items())
    ]


def _binding(b: Bound) -> str:
    return max(b.terms, key=lambda k: b.terms[k])


def _ratio(makespan: Any, bound: float | None) -> float | None:
    return float(makespan) / bound if bound is not None and bound > 0 else None


def _found_at(value: Any) -> list[Any] | None:
    """A run's sites_found_at: the engine's list, or runs.csv's JSON text of it."""
    if isinstance(value, str):
        try:
            value = json.loads(value)
        except ValueError:
            return None
    return list(value) if isinstance(value, (list, tuple)) else None
