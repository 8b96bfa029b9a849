"""The figures docs/spec.md §9 asks for, computed from a run's state and records."""

from __future__ import annotations

import statistics
from typing import TYPE_CHECKING, Any

from engine.scenario import ROBOT_TYPES

if TYPE_CHECKING:
    from engine.context import MissionContext

AUCTION_KINDS_REPORTED = ("scout_excavator", "excavator_hauler")

STATES: dict[str, tuple[str, ...]] = {
    "scout": ("idle", "scanning", "failed", "disabled"),
    "excavator": ("idle", "travelling", "digging", "waiting", "loading", "failed", "disabled"),
    "hauler": (
        "idle",
        "travelling",
        "waiting",
        "loading",
        "carrying",
        "unloading",
        "failed",
        "disabled",
    ),
}
"""The states each robot type reports time in (always all of them, so every run has the same
columns); a state outside these lists is reported too, under its own name."""


def open_time_stats(values: list[float]) -> dict[str, float | int | None]:
    if not values:
        return {"count": 0, "mean": None, "p50": None, "max": None}
    return {
        "count": len(values),
        "mean": statistics.fmean(values),
        "p50": statistics.median(values),
        "max": max(values),
    }


def mission_metrics(ctx: MissionContext) -> dict[str, Any]:
    distance = {t: 0.0 for t in ROBOT_TYPES}
    for r in ctx.robots.values():
        if r.rtype in distance:
            distance[r.rtype] += r.distance + (_partial(r))
    terrain, obs = ctx.terrain, ctx.observer
    in_state = {t: dict.fromkeys(STATES[t], 0.0) for t in ROBOT_TYPES}
    for r in ctx.robots.values():
        if r.rtype in in_state:
            per_type = in_state[r.rtype]
            for state, s in r.state_times().items():
                per_type[state] = per_type.get(state, 0.0) + s
    open_times: dict[str, list[float]] = {k: [] for k in AUCTION_KINDS_REPORTED}
    for rec in obs.auctions:
        if rec.status == "closed" and rec.kind in open_times and rec.open_time is not None:
            open_times[rec.kind].append(rec.open_time)
    out = {
        "sites_found": terrain.sites_found,
        "sites_total": len(terrain.sites),
        # per site in world order: when a scout first saw it (None: not yet found)
        "sites_found_at": [s.found_at for s in terrain.sites],
        "minerals_delivered": terrain.delivered,
        "minerals_total": terrain.minerals_total,
        "distance": distance,
        "distance_total": sum(distance.values()),
        # robot-seconds in each state, summed over the robots of a type
        "time_in_state": in_state,
        "auction_open_s": {k: open_time_stats(v) for k, v in open_times.items()},
        "auctions": len(obs.auctions),
        "bids": obs.bids,
        "declines": obs.declines,
        "reannouncements": sum(rec.reannouncements for rec in obs.auctions),
        "messages": ctx.bus.published,
        "failures": obs.failures,
        "reauctions": obs.reauctions,
        "minerals_dropped": obs.dropped,
        "minerals_recovered": obs.recovered,
        "messages_lost": ctx.bus.lost,
        "planner_queries": ctx.planner.stats.queries,
        "planner_ompl_queries": ctx.planner.stats.ompl_queries,
    }
    out.update(realism_metrics(ctx))
    return out


def _partial(robot: Any) -> float:
    """Distance driven so far on the current leg (a live mission mid-drive)."""
    m = robot.motion
    if m is None:
        return 0.0
    return float(min(m.length, (robot.env.now - m.t0) * m.speed))


def realism_metrics(ctx: MissionContext) -> dict[str, Any]:
    """The figures of the realism options that are on (none for the reference model)."""
    out: dict[str, Any] = {}
    if ctx.docks is not None:
        out.update(ctx.docks.metrics())
    if ctx.durations is not None:
        out["work_draws"] = ctx.durations.draws
    if ctx.energy is not None:
        out.update(ctx.energy.metrics(list(ctx.robots.values())))
    if ctx.radio is not None:
        out.update(ctx.radio.metrics())
    return out
