"""`GET /api/metrics` in the Prometheus text format: what an operator graphs and alerts on.

The values are read from the runner, the hub's statistics and the store when scraped, so
they come from a custom `prometheus_client` collector registered in a registry of the app's
own (`metrics_registry`), never the process-global one: tests start many apps in a process.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator

from prometheus_client import CollectorRegistry, generate_latest
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, Metric
from prometheus_client.registry import Collector

from app.live.hub import STATS
from app.live.modes import dropped_of
from app.live.runner import MissionRunner
from app.services.playback import Playback
from app.services.store import Store

CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"


def _q(values: list[float], q: float) -> float:
    if not values:
        return math.nan
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


class RegolithCollector(Collector):
    """Gauges and counters of the whole server, read at scrape time."""

    def __init__(self, runner: MissionRunner, store: Store, playback: Playback | None) -> None:
        self.runner = runner
        self.store = store
        self.playback = playback

    def collect(self) -> Iterator[Metric]:
        runner, store = self.runner, self.store
        live = [lm for lm in runner.live.values() if not lm.finishing]
        by_status: dict[str, int] = {"running": 0, "paused": 0}
        for lm in live:
            by_status[lm.status] = by_status.get(lm.status, 0) + 1
        m = GaugeMetricFamily(
            "regolith_missions_live", "Live missions by status.", labels=["status"]
        )
        for s, n in sorted(by_status.items()):
            m.add_metric([s], n)
        yield m

        speed = GaugeMetricFamily(
            "regolith_mission_speed",
            "Asked simulation speed (sim s per wall s; +Inf is max).",
            labels=["mission"],
        )
        sim_time = GaugeMetricFamily(
            "regolith_mission_sim_time_seconds", "Simulation time reached.", labels=["mission"]
        )
        auctions = CounterMetricFamily(
            "regolith_mission_auctions", "Auctions opened so far.", labels=["mission"]
        )
        for lm in live:
            key = [str(lm.id)]
            speed.add_metric(key, math.inf if lm.speed is None else lm.speed)
            sim_time.add_metric(key, lm.mission.now)
            auctions.add_metric(key, len(lm.mission.auctions))
        yield from (speed, sim_time, auctions)

        dropped = CounterMetricFamily(
            "regolith_field_dropped",
            "What field missions' processes dropped or refused from their bus (strangers, "
            "forgeries, replays, oversized or invalid payloads, world requests a robot may not "
            "make), by reason.",
            labels=["reason"],
        )
        totals = Counter(runner.field_dropped)
        for lm in runner.live.values():
            totals.update(dropped_of(lm.mission))
        for reason, n in sorted(totals.items()):
            dropped.add_metric([reason], n)
        yield dropped

        viewers = GaugeMetricFamily(
            "regolith_viewers", "Connected WebSocket viewers.", labels=["mission"]
        )
        backlog = GaugeMetricFamily(
            "regolith_viewer_backlog",
            "Ordered messages waiting for each mission's slowest viewer (dropped at "
            "REGOLITH_VIEWER_QUEUE); above 0 only while a viewer's socket is not keeping up.",
            labels=["mission"],
        )
        for mid, hub in sorted(runner.hubs.items()):
            viewers.add_metric([str(mid)], len(hub))
            backlog.add_metric([str(mid)], max((len(v.queue) for v in hub.viewers), default=0))
        yield from (viewers, backlog)

        # quantiles of a sliding window: a summary without _count and _sum
        delay = Metric(
            "regolith_frame_delay_seconds",
            "Server-side frame age when handed to a socket (last 5000 frames).",
            "summary",
        )
        delays = list(STATS.frame_delays)
        for q in ("0.5", "0.99"):
            delay.add_sample("regolith_frame_delay_seconds", {"quantile": q}, _q(delays, float(q)))
        yield delay

        yield CounterMetricFamily("regolith_frames_sent", "Frames sent.", STATS.frames_sent)
        yield CounterMetricFamily(
            "regolith_frames_dropped",
            "Frames merged into a newer one before they were sent (a viewer still sending).",
            STATS.frames_dropped,
        )
        yield CounterMetricFamily(
            "regolith_viewers_dropped", "Viewers closed for falling behind.", STATS.viewers_dropped
        )
        yield CounterMetricFamily("regolith_db_writes", "Write transactions.", store.writes)
        yield CounterMetricFamily(
            "regolith_db_write_seconds", "Time spent in write transactions.", store.write_seconds
        )
        yield GaugeMetricFamily(
            "regolith_db_write_seconds_max", "Longest write transaction.", store.write_max
        )
        yield GaugeMetricFamily("regolith_db_write_queue", "Writes waiting.", store.queued)
        yield from self._playback()

    def _playback(self) -> Iterator[Metric]:
        pb = self.playback
        if pb is not None:
            yield GaugeMetricFamily(
                "regolith_playback_engines",
                "Replay engines open: parked, or working for a request or a checkpoint.",
                pb.built - pb.closed,
            )
            yield GaugeMetricFamily(
                "regolith_playback_checkpoint_builds",
                "Missions whose playback checkpoints are being built now.",
                pb.fills,
            )
            yield CounterMetricFamily(
                "regolith_playback_engines_built", "Replay engines started from zero.", pb.built
            )
            yield CounterMetricFamily(
                "regolith_playback_engines_closed", "Replay engines closed.", pb.closed
            )
            yield GaugeMetricFamily(
                "regolith_playback_worker_up",
                "1 while the playback worker process runs (stopped when idle).",
                int(pb.worker_pid is not None),
            )
            yield CounterMetricFamily(
                "regolith_playback_worker_starts", "Playback worker processes started.", pb.starts
            )
            yield GaugeMetricFamily(
                "regolith_playback_worker_rss_bytes",
                "The playback worker's resident memory (0 when it is stopped).",
                pb.worker_rss(),
            )
            yield GaugeMetricFamily(
                "regolith_playback_queue",
                "Scrubs waiting for the playback worker or with it.",
                pb.queued,
            )
        yield CounterMetricFamily(
            "regolith_gc_full_collections",
            "Full garbage collections run while missions were live (the frozen heap doubled).",
            self.runner.gc_pause.full,
        )
        yield CounterMetricFamily(
            "regolith_gc_full_collection_seconds",
            "Time spent in those full collections (the event loop waits meanwhile).",
            self.runner.gc_pause.full_seconds,
        )


def metrics_registry(
    runner: MissionRunner, store: Store, playback: Playback | None = None
) -> CollectorRegistry:
    """A registry of this app's own holding its one collector."""
    registry = CollectorRegistry(auto_describe=False)
    registry.register(RegolithCollector(runner, store, playback))
    return registry


def render(registry: CollectorRegistry) -> bytes:
    """The exposition text (the caller holds the engine gate: the collector reads missions)."""
    return generate_latest(registry)
