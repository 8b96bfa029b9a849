"""What a mission shows its viewers: the static map, snapshots, light frames, the robot list,
the counters. JSON-ready dicts, positions at the current time (docs/engine-api.md).

`MissionViews` is the shape every mission shows, simulated or field; `SimulatedViews` reads
the engine's own robots and records (field mode's mission control reads what it hears)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

from engine.policies import coalition_partner

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.interface import AuctionView
    from engine.robots import Robot
    from engine.scenario import Scenario
    from engine.terrain import Terrain
    from engine.world import World


def tally(
    terrain: Terrain, auctions: Sequence[AuctionView], bids: int, declines: int, messages: int
) -> dict[str, int]:
    """The counters a frame carries: the terrain's, the auctions' and the bus's."""
    return {
        "sites_found": terrain.sites_found,
        "sites_total": len(terrain.sites),
        "minerals_delivered": terrain.delivered,
        "minerals_total": terrain.minerals_total,
        "auctions": len(auctions),
        "bids": bids,
        "declines": declines,
        "reannouncements": sum(a.reannouncements for a in auctions),
        "messages": messages,
    }


class MissionViews(ABC):
    """Mixed into a mission; the names below are the mission's, declared for the type checker.
    A mission says where its robots and counters come from; the shapes are this class's."""

    if TYPE_CHECKING:
        world: World
        scenario: Scenario
        seed: int
        status: str
        initial_policy: str
        actions: list[dict[str, Any]]

        @property
        def now(self) -> float: ...
        @property
        def policy(self) -> str: ...
        @property
        def auctions(self) -> Sequence[AuctionView]: ...

    @property
    @abstractmethod
    def terrain(self) -> Terrain:
        """The sites and piles, minerals on the ground, cells scanned, deliveries."""

    @abstractmethod
    def robot_dicts(self, full: bool) -> list[dict[str, Any]]:
        """Every robot (not the operator's console) as a frame shows it; `full`: as the
        robot list and snapshot show it (task, distance, path, enabled, partner)."""

    @abstractmethod
    def counters(self) -> dict[str, int]: ...

    def world_map(self) -> dict[str, Any]:
        return self.world.to_dict()

    def frame(self) -> dict[str, Any]:
        terrain = self.terrain
        return {
            "t": self.now,
            "status": self.status,
            "policy": self.policy,
            "robots": self.robot_dicts(False),
            "scanned": terrain.scanned_b64(),
            "scanned_count": terrain.scanned_count,
            "counters": self.counters(),
        }

    def robot_list(self) -> list[dict[str, Any]]:
        return self.robot_dicts(True)

    def snapshot(self) -> dict[str, Any]:
        return {
            "t": self.now,
            "status": self.status,
            "policy": self.policy,
            "scenario": self.scenario.name,
            "seed": self.seed,
            "robots": self.robot_list(),
            **self.terrain.picture(),
            "auctions": [a.to_dict() for a in self.auctions if a.status == "open"],
            "counters": self.counters(),
        }

    def run_figures(self) -> dict[str, Any]:
        """The figures that open a run's metrics, whatever ran it."""
        return {
            "policy": self.initial_policy,
            "seed": self.seed,
            "scenario": self.scenario.name,
            "status": self.status,
            "completed": self.status == "completed",
            "makespan_s": self.terrain.finished_at,
            "sim_time_s": self.now,
        }

    def policy_changes(self) -> int:
        return sum(1 for a in self.actions if a["kind"] == "set_policy")


class SimulatedViews(MissionViews):
    """The views of a simulated mission: its robots and records are the engine's own."""

    if TYPE_CHECKING:
        ctx: MissionContext
        robots: dict[str, Robot]

    @property
    def terrain(self) -> Terrain:
        return self.ctx.terrain

    def robot_dicts(self, full: bool) -> list[dict[str, Any]]:
        return [self._robot_dict(r, full) for r in self._robots()]

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
        ctx, obs = self.ctx, self.ctx.observer
        return tally(ctx.terrain, obs.auctions, obs.bids, obs.declines, ctx.bus.published)

    def stall_report(self) -> dict[str, Any]:
        """What is stuck: the open auctions, and what every robot is doing or waiting for."""
        ctx = self.ctx
        terrain, obs = ctx.terrain, ctx.observer
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
            "sites_unfound": len(terrain.sites) - terrain.sites_found,
        }
