"""What a mission shows its viewers: the static map, snapshots, light frames, the robot list.
JSON-ready dicts, positions interpolated at the current simulation time (docs/engine-api.md)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from engine.policies import coalition_partner

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.robots import Robot
    from engine.scenario import Scenario
    from engine.world import World


class MissionViews:
    """Mixed into `Mission`; the names below are the mission's, declared for the type checker."""

    if TYPE_CHECKING:
        ctx: MissionContext
        robots: dict[str, Robot]
        world: World
        scenario: Scenario
        seed: int
        status: str

        @property
        def now(self) -> float: ...
        @property
        def policy(self) -> str: ...

    def world_map(self) -> dict[str, Any]:
        return self.world.to_dict()

    def _robot_dict(self, r: Robot, full: bool) -> dict[str, Any]:
        (x, y), heading = r.mobility.position()
        d: dict[str, Any] = {
            "name": r.name,
            "type": r.rtype,
            "state": r.state,
            "x": x,
            "y": y,
            "heading": heading,
            "load": r.load(),
            "alive": r.alive,
        }
        if r.battery is not None:
            d["charge"] = round(r.battery.fraction(self.now), 4)
        if full:
            cur = r.current
            d["task"] = (
                None
                if cur is None
                else f"{cur.task_type}@({cur.location[0]:.1f},{cur.location[1]:.1f})"
            )
            d["distance"] = r.distance
            d["path"] = [[p[0], p[1]] for p in r.mobility.remaining_route()]
            d["enabled"] = r.enabled and not r.leaving
            d["partner"] = (
                coalition_partner(r.name)
                if self.ctx.policy.coalitions() and r.rtype != "scout"
                else None
            )
        return d

    def _robots(self) -> Iterable[Robot]:
        return (r for r in self.robots.values() if r.rtype != "operator")

    def counters(self) -> dict[str, int]:
        ctx = self.ctx
        field, obs = ctx.field, ctx.observer
        return {
            "sites_found": field.sites_found,
            "sites_total": len(field.sites),
            "minerals_delivered": field.delivered,
            "minerals_total": field.minerals_total,
            "auctions": len(obs.auctions),
            "bids": obs.bids,
            "declines": obs.declines,
            "reannouncements": sum(a.reannouncements for a in obs.auctions),
            "messages": ctx.bus.published,
        }

    def stall_report(self) -> dict[str, Any]:
        """What is stuck: the open auctions, and what every robot is doing or waiting for."""
        ctx = self.ctx
        field, obs = ctx.field, ctx.observer
        auctions = [
            {
                "auction_id": a.id,
                "task_id": a.task_id,
                "auctioneer": a.auctioneer,
                "rounds": a.round,
                "declines": sum(1 for w in a.awards if w.outcome != "accepted"),
            }
            for a in obs.auctions
            if a.status == "open"
        ]
        robots = [
            {
                "name": r.name,
                "state": r.state,
                "task": None if r.current is None else r.current.task_id,
                "queued": len(r.queue),
                "waiting_for": getattr(r, "waiting_for", None),
            }
            for r in self._robots()
        ]
        return {
            "stalled_for_s": self.now - obs.progress_at,
            "open_auctions": auctions,
            "robots": robots,
            "minerals": ctx.minerals_in(),
            "sites_unfound": len(field.sites) - field.sites_found,
        }

    def frame(self) -> dict[str, Any]:
        return {
            "t": self.now,
            "status": self.status,
            "policy": self.policy,
            "robots": [self._robot_dict(r, False) for r in self._robots()],
            "scanned": self.ctx.field.scanned_b64(),
            "scanned_count": self.ctx.field.scanned_count,
            "counters": self.counters(),
        }

    def robot_list(self) -> list[dict[str, Any]]:
        return [self._robot_dict(r, True) for r in self._robots()]

    def snapshot(self) -> dict[str, Any]:
        field, obs = self.ctx.field, self.ctx.observer
        return {
            "t": self.now,
            "status": self.status,
            "policy": self.policy,
            "scenario": self.scenario.name,
            "seed": self.seed,
            "robots": self.robot_list(),
            **field.picture(),
            "auctions": [a.to_dict() for a in obs.auctions if a.status == "open"],
            "counters": self.counters(),
        }
