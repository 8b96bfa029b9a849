"""`GET /api/metrics` in the Prometheus text format: what an operator graphs and alerts on."""

from __future__ import annotations

import math

from app.live.hub import STATS
from app.live.runner import MissionRunner
from app.services.store import Store


def _q(values: list[float], q: float) -> float:
    if not values:
        return math.nan
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def _num(x: float) -> str:
    if math.isnan(x):
        return "NaN"
    return "+Inf" if math.isinf(x) else repr(float(x))


def render(runner: MissionRunner, store: Store) -> str:
    """Gauges and counters of the whole server (the caller holds the engine gate)."""
    lines: list[str] = []

    def metric(name: str, kind: str, help_: str, samples: list[tuple[str, float]]) -> None:
        lines.append(f"# HELP {name} {help_}")
        lines.append(f"# TYPE {name} {kind}")
        lines.extend(f"{name}{labels} {_num(value)}" for labels, value in samples)

    live = [lm for lm in runner.live.values() if not lm.finishing]
    by_status: dict[str, int] = {"running": 0, "paused": 0}
    for lm in live:
        by_status[lm.status] = by_status.get(lm.status, 0) + 1
    metric(
        "regolith_missions_live",
        "gauge",
        "Live missions by status.",
        [(f'{{status="{s}"}}', n) for s, n in sorted(by_status.items())],
    )
    each = [(f'{{mission="{lm.id}"}}', lm) for lm in live]
    metric(
        "regolith_mission_speed",
        "gauge",
        "Asked simulation speed (sim s per wall s; +Inf is max).",
        [(k, math.inf if lm.speed is None else lm.speed) for k, lm in each],
    )
    metric(
        "regolith_mission_sim_time_seconds",
        "gauge",
        "Simulation time reached.",
        [(k, lm.mission.now) for k, lm in each],
    )
    metric(
        "regolith_mission_auctions_total",
        "counter",
        "Auctions opened so far.",
        [(k, len(lm.mission.auctions)) for k, lm in each],
    )
    metric(
        "regolith_viewers",
        "gauge",
        "Connected WebSocket viewers.",
        [(f'{{mission="{mid}"}}', len(hub)) for mid, hub in sorted(runner.hubs.items())],
    )
    metric(
        "regolith_viewer_backlog",
        "gauge",
        "Ordered messages waiting for each mission's slowest viewer (dropped at "
        "REGOLITH_VIEWER_QUEUE); above 0 only while a viewer's socket is not keeping up.",
        [
            (f'{{mission="{mid}"}}', max((len(v.queue) for v in hub.viewers), default=0))
            for mid, hub in sorted(runner.hubs.items())
        ],
    )
    delays = list(STATS.frame_delays)
    metric(
        "regolith_frame_delay_seconds",
        "summary",
        "Server-side frame age when handed to a socket (last 5000 frames).",
        [('{quantile="0.5"}', _q(delays, 0.5)), ('{quantile="0.99"}', _q(delays, 0.99))],
    )
    metric("regolith_frames_sent_total", "counter", "Frames sent.", [("", STATS.frames_sent)])
    metric(
        "regolith_frames_dropped_total",
        "counter",
        "Stale frames replaced before they were sent.",
        [("", STATS.frames_dropped)],
    )
    metric(
        "regolith_viewers_dropped_total",
        "counter",
        "Viewers closed for falling behind.",
        [("", STATS.viewers_dropped)],
    )
    metric("regolith_db_writes_total", "counter", "Write transactions.", [("", store.writes)])
    metric(
        "regolith_db_write_seconds_total",
        "counter",
        "Time spent in write transactions.",
        [("", store.write_seconds)],
    )
    metric(
        "regolith_db_write_seconds_max",
        "gauge",
        "Longest write transaction.",
        [("", store.write_max)],
    )
    metric("regolith_db_write_queue", "gauge", "Writes waiting.", [("", store.queued)])
    return "\n".join(lines) + "\n"
